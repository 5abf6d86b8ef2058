"""The companion app over real UDP: the sim behind its own runner (thread), two companions
behind theirs (thread), a fake GCS socket; and the ``ridsafe companion`` command line."""

from __future__ import annotations

import argparse
import socket
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from ridsafe.common import codec
from ridsafe.common import messages as m
from ridsafe.common.config import from_mapping, to_mapping
from ridsafe.common.errors import ConfigError
from ridsafe.common.logsink import MemorySink
from ridsafe.common.runner import UdpRunner
from ridsafe.common.udp import UdpEndpoint
from ridsafe.companion.app import CompanionApp, CompanionFleet, Connections
from ridsafe.companion.companion import Companion
from ridsafe.companion.config import CompanionConfig, CompanionSpec, OnArrival
from ridsafe.companion.planners import PLANNERS, StraightLinePlanner
from ridsafe.sim_backend.app import make_runner
from ridsafe.sim_backend.config import SimConfig, SimPorts
from ridsafe.sim_backend.world import EndpointKind, SimBackend
from ridsafe.tools.cli import companion_cmd
from ridsafe.tools.run.scenario import load_scenario_file
from tests.companion.test_companion_core import make_scenario

SPEED = 5.0
WALL_BUDGET_S = 20.0


def _free_base_port() -> int:
    """A port p with p and p + 10 free for UDP (as far as one can tell without holding them)."""
    for _ in range(20):
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            probe.bind(("127.0.0.1", 0))
            base = int(probe.getsockname()[1])
        if not 1024 <= base <= 65535 - 2560:
            continue
        try:
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as other:
                other.bind(("127.0.0.1", base + 10))
        except OSError:
            continue
        return base
    raise RuntimeError("no free UDP port pair")


def _start(target: Callable[[], object], name: str) -> threading.Thread:
    thread = threading.Thread(target=target, name=name, daemon=True)
    thread.start()
    return thread


@pytest.fixture
def sim_runner() -> Iterator[tuple[SimBackend, UdpRunner, int]]:
    scenario = make_scenario(2)
    base = _free_base_port()
    ports = SimPorts(companion_base=base, gcs_out_enabled=False)
    backend = SimBackend(scenario, SimConfig(ports=ports), [EndpointKind.COMPANION])
    runner = make_runner(backend, ports, speed=SPEED)
    thread = _start(runner.run, "sim")
    yield backend, runner, base
    runner.stop()
    thread.join(timeout=5.0)
    runner.close()


@pytest.mark.udp
def test_two_companions_over_udp_arm_take_off_and_report_to_the_gcs(
    sim_runner: tuple[SimBackend, UdpRunner, int],
) -> None:
    backend, _, base = sim_runner
    gcs = UdpEndpoint("127.0.0.1", 0)
    gcs_link = codec.MavlinkLink(250, 190)
    sinks = {i: MemorySink() for i in (1, 2)}
    companions = [
        Companion(
            CompanionSpec.from_scenario(backend.scenario, i),
            CompanionConfig(),
            StraightLinePlanner(),
            sinks[i],
        )
        for i in (1, 2)
    ]
    gcs_conn = f"udpout:127.0.0.1:{gcs.local_address[1]}"
    connections = {
        i: Connections(f"udpout:127.0.0.1:{base + 10 * (i - 1)}", gcs_conn) for i in (1, 2)
    }
    app = CompanionApp(companions, connections, speed=SPEED)
    thread = _start(app.run, "companions")
    heard: list[codec.Received] = []
    try:
        deadline = time.monotonic() + WALL_BUDGET_S
        while time.monotonic() < deadline:
            for data, _ in gcs.recv_all():
                heard.extend(gcs_link.feed(data))
            altitudes = [c.own.gpi.relative_alt_m if c.own.gpi else 0.0 for c in companions]
            observers = {r.src_system for r in heard if isinstance(r.message, m.ObservationRows)}
            if min(altitudes) > 10.0 and observers == {1, 2}:
                break
            time.sleep(0.05)
    finally:
        app.stop()
        thread.join(timeout=5.0)
        app.close()
        gcs.close()
    truth = backend.truth()
    assert all(truth.armed[:2]), "both vehicles armed"
    assert min(truth.p_enu_m[:2, 2]) > 10.0, f"both above 10 m, got {truth.p_enu_m[:2, 2]}"
    by_sender = {
        r.src_system: r.message.observation(0)
        for r in heard
        if isinstance(r.message, m.ObservationRows)
    }
    assert by_sender[1].uas_id == "RSAF800000002" and by_sender[2].uas_id == "RSAF800000001"
    for companion in companions:
        counters = companion.counters_snapshot()
        assert counters["autopilot.bad_data"] == 0
        assert counters["observations.sent_before_gcs_seen"] > 0  # this GCS never answers
        # the clocks started apart: times that leave the companion are on the sim's clock
        assert abs(companion.sim_time(companion.t_s) - backend.t_s) < 1.0


def test_the_fleet_routes_by_vehicle_and_counts_unknown_endpoints() -> None:
    scenario = make_scenario(2)
    config = CompanionConfig()
    companions = [
        Companion(
            CompanionSpec.from_scenario(scenario, i), config, StraightLinePlanner(), MemorySink()
        )
        for i in (1, 2)
    ]
    fleet = CompanionFleet(companions)
    out = fleet.handle(0.0, [("v9/autopilot", b"x"), ("v1/elsewhere", b"x"), ("v2/gcs", b"\x00")])
    assert fleet.unknown_endpoint == 2
    assert companions[1].counters_snapshot()["companion.datagrams_in"] == 1
    assert {name for name, _ in out} == {"v1/autopilot", "v1/gcs", "v2/autopilot", "v2/gcs"}
    with pytest.raises(ValueError, match="system id"):
        CompanionFleet([companions[0], companions[0]])


# --- the command line -------------------------------------------------------------------------


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="ridsafe")
    companion_cmd.register(parser.add_subparsers(dest="command"))
    return parser


def test_vehicle_lists_and_ranges_parse() -> None:
    assert companion_cmd.parse_vehicles("2", 4) == [2]
    assert companion_cmd.parse_vehicles("1-4", 4) == [1, 2, 3, 4]
    assert companion_cmd.parse_vehicles("3,1", 4) == [1, 3]
    for bad in ("0", "5", "2-1", "x", "1-"):
        with pytest.raises(ValueError, match="--vehicle"):
            companion_cmd.parse_vehicles(bad, 4)


SCENARIO_YAML = """
scenario:
  origin: {lat_deg: 36.1447, lon_deg: -86.8027, alt_m: 180.0}
  aircraft:
    - {serial: RSAF800000001, start_enu_m: [0.0, 0.0, 0.0], goal_enu_m: [100.0, 0.0, 0.0]}
    - {serial: RSAF800000002, start_enu_m: [50.0, 0.0, 0.0], goal_enu_m: [0.0, 90.0, 0.0]}
sim:
  ports: {companion_base: 27760}
companion:
  on_arrival: land
  cruise_speed_m_s: 6.0
planner:
  horizon_s: 8.0
"""


def test_the_scenario_files_companion_and_planner_sections_are_read(tmp_path: Path) -> None:
    path = tmp_path / "s.yaml"
    path.write_text(SCENARIO_YAML, encoding="utf-8")
    loaded = load_scenario_file(path, {"companion.cruise_speed_m_s": 5.0})
    assert loaded.companion.on_arrival is OnArrival.LAND
    assert loaded.companion.cruise_speed_m_s == 5.0
    assert loaded.planner.horizon_s == 8.0
    assert loaded.sim.ports.companion_base == 27760
    bad = tmp_path / "bad.yaml"
    bad.write_text(SCENARIO_YAML.replace("cruise_speed_m_s: 6.0", "cruise_speed: 6.0"), "utf-8")
    with pytest.raises(ConfigError, match=r"companion.*cruise_speed"):
        load_scenario_file(bad)


def test_the_cli_refuses_one_autopilot_for_several_vehicles(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "s.yaml"
    path.write_text(SCENARIO_YAML, encoding="utf-8")
    args = _parser().parse_args(
        ["companion", str(path), "--vehicle", "1-2", "--autopilot", "udpout:127.0.0.1:5760"]
    )
    assert args.func(args) == 2
    assert "single --vehicle" in capsys.readouterr().err


def test_the_cli_runs_with_nobody_listening_and_prints_its_counters(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "s.yaml"
    path.write_text(SCENARIO_YAML.replace("27760", str(_free_base_port())), encoding="utf-8")
    gcs = f"udpout:127.0.0.1:{_free_base_port()}"
    argv = ["companion", str(path), "--vehicle", "1-2", "--speed", "10", "--duration", "1.5"]
    args = _parser().parse_args([*argv, "--gcs", gcs])
    assert args.func(args) == 0
    out = capsys.readouterr().out
    assert "companion/1 counters" in out and "companion/2 counters" in out
    assert "companion 1: ended in WAIT_HEARTBEAT" in out


def test_the_planner_choice_comes_from_the_registry() -> None:
    assert "straight-line" in PLANNERS
    with pytest.raises(SystemExit):
        _parser().parse_args(["companion", "--vehicle", "1", "--planner", "nonesuch"])


def test_companion_config_round_trips_through_plain_data_and_names_bad_keys() -> None:
    config = CompanionConfig(on_arrival=OnArrival.LAND, takeoff_alt_m=15.0)
    assert from_mapping(CompanionConfig, to_mapping(config), "x.yaml") == config
    with pytest.raises(ConfigError, match="rid_static_period_s"):
        from_mapping(CompanionConfig, {"rid_static_period_s": 3.5}, "x.yaml")  # > 3 s
    with pytest.raises(ConfigError, match="cruise_speed_m_s"):
        from_mapping(CompanionConfig, {"cruise_speed_m_s": 12.0}, "x.yaml")
