"""The one factory of the cores (``run.cores``): lockstep and the standalone commands (what a
live run starts) build equal cores from one scenario file, and every section reaches its core.
"""

from __future__ import annotations

import argparse
import dataclasses
import stat
from pathlib import Path

import numpy as np
import pytest

from ridsafe.common.logsink import MemorySink, NullSink
from ridsafe.gcs.config import ClockSource
from ridsafe.sim_backend.world import EndpointKind
from ridsafe.tools.cli import companion_cmd, gcs_cmd, sim_cmd
from ridsafe.tools.run import cores, live, lockstep
from ridsafe.tools.run.scenario import REPO_ROOT, ScenarioFile, load_scenario_file, with_aircraft

CONFIG = str(REPO_ROOT / "configs" / "default.yaml")
#: Unsigned GCS links (lockstep derives a key, a live run writes a random one: either way
#: the bytes differ) and no GCS stream from the sim (a lockstep run has nobody listening).
SAME_WIRE = {"run.sign_gcs_links": False, "sim.ports.gcs_out_enabled": False}
TICKS = 400  # 20 s of sim time at 50 ms: take-off, cruise and the GCS's first alert


def parse(command: str, *argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="ridsafe")
    subparsers = parser.add_subparsers(dest="command")
    for module in (sim_cmd, gcs_cmd, companion_cmd):
        module.register(subparsers)
    overrides = [f"--set={key}={str(value).lower()}" for key, value in SAME_WIRE.items()]
    return parser.parse_args([command, CONFIG, *overrides, *argv])


def standalone(planner: str) -> lockstep.Lockstep:
    """The cores ``ridsafe sim``, ``ridsafe gcs --clock local`` and ``ridsafe companion``
    build from their arguments, wired as a lockstep run wires its own."""
    sim_args = parse("sim")
    loaded = sim_cmd.load_from_args(sim_args)
    sim = sim_cmd.build_backend(loaded, NullSink())
    gcs = gcs_cmd.build_gcs(parse("gcs", "--clock", "local"))
    n = len(loaded.scenario.aircraft)
    companion_args = parse("companion", "--vehicle", f"1-{n}", "--planner", planner)
    vehicles = companion_cmd.parse_vehicles(companion_args.vehicle, n)
    built = companion_cmd.build_companions(companion_args, loaded, vehicles, NullSink(), None)
    companions = {c.spec.sysid: c for c in built}
    return lockstep.connect(sim, companions, gcs, loaded.run.lockstep_tick_s)


def from_lockstep(planner: str) -> lockstep.Lockstep:
    return lockstep.build(load_scenario_file(CONFIG, SAME_WIRE), planner, NullSink())


@pytest.mark.parametrize("planner", ["aware", "trust-rid"])
def test_lockstep_and_the_standalone_commands_build_the_same_cores(planner: str) -> None:
    ours, theirs = from_lockstep(planner), standalone(planner)
    assert ours.sim.scenario == theirs.sim.scenario
    assert ours.sim.config == theirs.sim.config
    assert ours.gcs.config == theirs.gcs.config
    assert sorted(ours.companions) == sorted(theirs.companions)
    for sysid, companion in ours.companions.items():
        other = theirs.companions[sysid]
        assert (companion.spec, companion.config) == (other.spec, other.config)
        assert type(companion.planner) is type(other.planner)
    for _ in range(TICKS):
        ours.step()
        theirs.step()
    # Flown alike, byte for byte: the same truth, phases, GCS counters and router traffic.
    a, b = ours.sim.truth(), theirs.sim.truth()
    np.testing.assert_array_equal(a.p_enu_m, b.p_enu_m)
    np.testing.assert_array_equal(a.armed, b.armed)
    assert [c.phase for c in ours.companions.values()] == [
        c.phase for c in theirs.companions.values()
    ]
    assert ours.gcs.counter_values() == theirs.gcs.counter_values()
    assert ours.gcs.counter_values()["cycles"] > 0
    assert (ours.router.delivered, ours.router.undeliverable) == (
        theirs.router.delivered,
        theirs.router.undeliverable,
    )


def test_the_planner_is_built_from_the_companion_and_planner_sections() -> None:
    loaded = load_scenario_file(
        CONFIG,
        {
            "companion.cruise_speed_m_s": 6.0,
            "companion.replan_period_s": 1.0,
            "planner.d_safe_m": 80.0,
            "scenario.seed": 7,
        },
    )
    settings = cores.planner_settings(loaded, 2)
    assert (settings.sysid, settings.seed) == (2, 7)
    assert (settings.cruise_speed_m_s, settings.replan_period_s) == (6.0, 1.0)
    assert settings.lookahead_s == loaded.companion.lookahead_s
    assert settings.approach_radius_m == loaded.companion.approach_radius_m
    assert settings.arrival_radius_m == loaded.companion.arrival_radius_m
    assert settings.config == loaded.planner and settings.config.d_safe_m == 80.0
    sink = MemorySink()
    companion = cores.make_companion(loaded, 2, "trust-rid", sink, None)
    assert companion.spec.sysid == 2 and companion.config == loaded.companion
    assert companion.sink is sink
    assert list(cores.make_companions(loaded, [3, 1], "aware", sink, None)) == [3, 1]


def test_the_gcs_takes_its_clock_from_the_caller_and_the_rest_from_the_file() -> None:
    loaded = load_scenario_file(CONFIG, {"gcs.cycle_s": 0.5})
    default = cores.make_gcs(loaded, NullSink(), None)
    peers = cores.make_gcs(loaded, NullSink(), None, clock=ClockSource.PEERS)
    assert default.config == loaded.gcs
    assert peers.config.clock is ClockSource.PEERS and peers.config.cycle_s == 0.5
    assert peers.config == dataclasses.replace(default.config, clock=ClockSource.PEERS)


@pytest.mark.parametrize(
    ("enabled", "expected"),
    [
        (True, (EndpointKind.COMPANION, EndpointKind.GCS)),
        (False, (EndpointKind.COMPANION,)),
    ],
)
def test_a_live_sim_streams_to_a_gcs_when_the_ports_say_so(
    enabled: bool, expected: tuple[EndpointKind, ...]
) -> None:
    loaded = load_scenario_file(CONFIG, {"sim.ports.gcs_out_enabled": enabled})
    assert cores.live_sim_endpoints(loaded) == expected
    assert cores.LOCKSTEP_SIM_ENDPOINTS == (EndpointKind.COMPANION,)


def _scenario(aircraft: int, sign: bool) -> ScenarioFile:
    overrides = {"run.sign_gcs_links": sign}
    return with_aircraft(load_scenario_file(CONFIG, overrides), aircraft)


def test_a_live_run_starts_the_standalone_commands(tmp_path: Path) -> None:
    loaded = _scenario(10, sign=True)
    scenario_path = tmp_path / "scenario.yaml"
    started = live.children(loaded, "aware", tmp_path, scenario_path, 2.0, 1234.5)
    assert [c.name for c in started] == ["sim", "gcs", "companions-1-8", "companions-9-10"]
    commands = [c.argv[c.argv.index("ridsafe.tools.cli") + 1] for c in started]
    assert commands == ["sim", "gcs", "companion", "companion"]
    for child, command in zip(started, commands, strict=True):
        assert child.argv[child.argv.index(command) + 1] == str(scenario_path)
        assert child.argv[child.argv.index("--t0-unix") + 1] == "1234.5"
        assert child.argv[child.argv.index("--log") + 1] == str(
            tmp_path / "parts" / f"{child.name}.mcap"
        )
    key = tmp_path / "mavlink.key"
    assert stat.S_IMODE(key.stat().st_mode) == 0o600 and len(key.read_text()) == 64
    for child in started[1:]:  # the GCS and every companion share the key; the sim has none
        assert child.argv[child.argv.index("--signing-key") + 1] == str(key)
    assert "--signing-key" not in started[0].argv
    assert started[2].argv[started[2].argv.index("--vehicle") + 1] == "1-8"


def test_an_unsigned_live_run_writes_no_key(tmp_path: Path) -> None:
    started = live.children(_scenario(2, sign=False), "trust-rid", tmp_path, tmp_path / "s", 1, 0)
    assert not (tmp_path / "mavlink.key").exists()
    assert all("--signing-key" not in child.argv for child in started)
    (companions,) = started[2:]
    assert companions.argv[companions.argv.index("--planner") + 1] == "trust-rid"
