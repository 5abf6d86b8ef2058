"""The GCS over real UDP sockets on 127.0.0.1: the runner's multi-peer endpoint, the core
behind it with two companion sockets, and the ``ridsafe gcs`` command (through its own parser).
"""

from __future__ import annotations

import argparse
import select
import signal
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import pytest

from ridsafe.common import codec, topics
from ridsafe.common import messages as m
from ridsafe.common.clock import EpochClock, MonotonicClock
from ridsafe.common.logsink import MemorySink
from ridsafe.common.runner import UdpRunner, parse_peer
from ridsafe.common.shell import Datagrams
from ridsafe.common.udp import UdpEndpoint
from ridsafe.gcs.app import make_runner
from ridsafe.gcs.config import GcsConfig
from ridsafe.gcs.gcs import Gcs
from ridsafe.gcs.pipeline_api import CycleOutput
from ridsafe.tools.cli import gcs_cmd
from ridsafe.tools.run import cores
from ridsafe.tools.run.scenario import ScenarioFile, load_scenario_file
from ridsafe.tools.runlog.reader import read_records
from tests.gcs.test_gcs_core import COMPANION_COMPONENT, KEY, FakePipeline, report
from tests.gcs.test_ingest import ORIGIN

pytestmark = pytest.mark.udp


def drain(endpoint: UdpEndpoint, count: int, timeout_s: float = 2.0) -> list[bytes]:
    got: list[bytes] = []
    deadline = time.monotonic() + timeout_s
    while len(got) < count and (remaining := deadline - time.monotonic()) > 0:
        select.select([endpoint], [], [], remaining)
        got.extend(data for data, _ in endpoint.recv_all())
    return got


# --- the runner's multi-peer endpoint --------------------------------------------------------


class EchoCore:
    """Answers every datagram, reversed, to the endpoint name it came from."""

    def __init__(self) -> None:
        self.seen: list[str] = []

    def handle(self, now_s: float, inbound: Datagrams) -> Datagrams:
        self.seen.extend(name for name, _ in inbound)
        out = [(name, data[::-1]) for name, data in inbound]
        return [*out, ("hub@c3", b"not an address"), ("nowhere", b"x")] if out else []


def test_multi_peer_endpoint_names_each_sender_and_answers_it() -> None:
    core = EchoCore()
    endpoints = {"hub": UdpEndpoint(), "plain": UdpEndpoint()}
    runner = UdpRunner(core, endpoints, MonotonicClock(), 0.01, multi_peer={"hub"})
    a, b = UdpEndpoint(remote=endpoints["hub"].local_address), UdpEndpoint()
    c = UdpEndpoint(remote=endpoints["plain"].local_address)
    try:
        b.send(b"from b", endpoints["hub"].local_address)
        a.send(b"from a")
        c.send(b"from c")
        time.sleep(0.05)
        runner.run(until_s=0.05)
        assert drain(a, 1) == [b"a morf"] and drain(b, 1) == [b"b morf"]
        assert drain(c, 1) == [b"c morf"]  # a plain endpoint still answers its last peer
        names = {f"hub@127.0.0.1:{e.local_address[1]}" for e in (a, b)}
        assert set(core.seen) == names | {"plain"}
        assert runner.stats.unsent_bad_peer == 1 and runner.stats.unknown_endpoint_out == 1
    finally:
        runner.close()
        for e in (a, b, c):
            e.close()


def test_multi_peer_names_must_be_endpoints() -> None:
    with UdpEndpoint() as endpoint, pytest.raises(ValueError, match="not endpoints"):
        UdpRunner(EchoCore(), {"hub": endpoint}, MonotonicClock(), multi_peer={"gcs"})


@pytest.mark.parametrize(
    ("peer", "expected"),
    [
        ("127.0.0.1:40123", ("127.0.0.1", 40123)),
        ("c3", None),
        ("127.0.0.1:0", None),
        ("127.0.0.1:70000", None),
        ("localhost:80", None),
        (":80", None),
    ],
)
def test_parse_peer(peer: str, expected: tuple[str, int] | None) -> None:
    assert parse_peer(peer) == expected


# --- the GCS core behind a real socket -------------------------------------------------------


class _Companions:
    """Two companions on their own sockets: a report every 0.5 s, replies decoded."""

    def __init__(self, gcs_address: tuple[str, int]) -> None:
        self.sockets = {i: UdpEndpoint(remote=gcs_address) for i in (1, 2)}
        self.links = {i: codec.MavlinkLink(i, COMPANION_COMPONENT) for i in (1, 2)}
        self.received: dict[int, list[m.Message]] = {1: [], 2: []}
        self.next_report_s = 0.0

    def tick(self, now_s: float) -> None:
        if now_s >= self.next_report_s:
            rid_ts = 1200.0 + round(self.next_report_s * 2) / 2
            for i, sock in self.sockets.items():
                sock.send(self.links[i].pack(report(i, now_s, rid_ts)))
            self.next_report_s += 0.5
        for i, sock in self.sockets.items():
            for data, _ in sock.recv_all():
                self.received[i].extend(r.message for r in self.links[i].feed(data))

    def got(self, kind: type[m.Message]) -> bool:
        return all(any(isinstance(x, kind) for x in msgs) for msgs in self.received.values())

    def close(self) -> None:
        for sock in self.sockets.values():
            sock.close()


def test_two_companions_over_udp_both_get_regions_back() -> None:
    pipeline = FakePipeline(alert_at_s=0.0)
    gcs = Gcs(GcsConfig(), ORIGIN, pipeline, MemorySink())
    runner = make_runner(gcs, "udpin:127.0.0.1:0", speed=4.0, tick_s=0.05)
    companions = _Companions(runner.endpoints["companions"].local_address)
    ports = {i: s.local_address[1] for i, s in companions.sockets.items()}

    def on_tick(now_s: float) -> None:
        companions.tick(now_s)
        both = any(t.rx_sysid.tolist() == [1, 2] for _, txs in pipeline.calls for t in txs)
        if both and companions.got(m.UnsafeRegionMsg) and companions.got(m.SpoofAlert):
            runner.stop()

    try:
        end_s = runner.run(until_s=20.0, on_tick=on_tick)
    finally:
        runner.close()
        companions.close()
    assert end_s < 20.0, f"gave up: {gcs.counter_values()}"
    assert gcs.sysid_peers == {i: f"127.0.0.1:{port}" for i, port in ports.items()}
    regions = [x for x in companions.received[2] if isinstance(x, m.UnsafeRegionMsg)]
    assert regions[0].uas_id == "RSAF800000666" and regions[0].track_id == 7
    assert gcs.counter_values()["link_bad_data"] == 0


# --- the command line ------------------------------------------------------------------------


def parse(argv: Sequence[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="ridsafe")
    gcs_cmd.register(parser.add_subparsers(dest="command"))
    return parser.parse_args(argv)


def _fake_pipeline(_loaded: ScenarioFile) -> FakePipeline:
    return FakePipeline()


def test_gcs_command_runs_signed_and_logs(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    monkeypatch.setattr(cores, "make_estimation_pipeline", _fake_pipeline)
    key_file = tmp_path / "gcs.key"
    key_file.write_text(KEY.hex())
    argv = ["gcs", "--listen", "udpin:127.0.0.1:0", "--duration", "1", "--speed", "5"]
    argv += ["--signing-key", str(key_file), "--set", "scenario.seed=3"]
    log = tmp_path / "gcs.mcap"
    argv += ["--log", str(log)]
    args = parse(argv)
    assert args.func(args) == 0
    out = capsys.readouterr().out
    assert "GCS listening on udpin:127.0.0.1:" in out and "(signed)" in out
    records = [(topic, rec) for topic, _, rec in read_records(log)]
    assert any(t == topics.APP_COUNTERS and r["app"] == "gcs" for t, r in records)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        # --speed 0 and --listen udpout:...: refused while parsing, naming the flag
        # (tests/tools/cli/test_cli_errors.py)
        (["--signing-key", "EMPTY"], "signing key file is empty"),
        (["--set", "scenario.seed=-1"], "seed"),
    ],
)
def test_gcs_command_reports_bad_arguments(
    extra: list[str],
    message: str,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    tmp_path: Path,
) -> None:
    monkeypatch.setattr(cores, "make_estimation_pipeline", _fake_pipeline)
    empty = tmp_path / "empty.key"
    empty.write_text("")
    args = parse(["gcs", *(str(empty) if x == "EMPTY" else x for x in extra)])
    assert args.func(args) == 2
    err = capsys.readouterr().err
    assert err.startswith("ridsafe gcs:") and message in err


def test_epoch_clock_reads_zero_at_the_shared_instant() -> None:
    wall = [1000.0]
    clock = EpochClock(2.0, 1001.5, lambda: wall[0])
    assert clock.now_s() == -3.0
    wall[0] = 1002.0
    assert clock.now_s() == 1.0
    assert clock.wall_delay_s(1.0) == 0.5 and clock.wall_delay_s(-1.0) == 0.0


def test_gcs_command_starts_sim_time_at_t0_unix(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(cores, "make_estimation_pipeline", _fake_pipeline)
    t0 = time.time() + 0.3
    argv = ["gcs", "--listen", "udpin:127.0.0.1:0", "--t0-unix", repr(t0), "--duration", "0.25"]
    args = parse(argv)
    assert args.func(args) == 0
    assert time.time() >= t0 + 0.25  # waited for t0, then ran 0.25 s of sim time
    assert f"sim time: 0 at UNIX time {t0:.3f}" in capsys.readouterr().out


def test_default_pipeline_from_the_scenario_file() -> None:
    pipeline = cores.make_estimation_pipeline(load_scenario_file())
    assert isinstance(pipeline.step(0.0, []), CycleOutput)


_CLI = """
import argparse, sys
from ridsafe.tools.cli import gcs_cmd
parser = argparse.ArgumentParser()
gcs_cmd.register(parser.add_subparsers())
args = parser.parse_args(sys.argv[1:])
sys.exit(args.func(args))
"""


def test_sigterm_ends_the_gcs_cleanly_with_its_log_closed(tmp_path: Path) -> None:
    log = tmp_path / "gcs.mcap"
    argv = ["gcs", "--listen", "udpin:127.0.0.1:0", "--clock", "local", "--log", str(log)]
    root = Path(__file__).resolve().parents[2]
    proc = subprocess.Popen(
        [sys.executable, "-c", _CLI, *argv], cwd=root, stdout=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout is not None
        ready, _, _ = select.select([proc.stdout], [], [], 20.0)
        assert ready and "GCS listening" in proc.stdout.readline()
        # A few cycles: 0.6 s gave one on a host loaded by a sweep on both cores.
        time.sleep(1.5)
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=10) == 0
    finally:
        proc.kill()
        proc.wait()
    records = list(read_records(log))
    cycles = [t for topic, t, _ in records if topic == topics.GCS_CYCLE]
    # 4 Hz: every cycle on the 0.25 s grid (a loaded host may skip one, never shift one)
    assert len(cycles) >= 2
    assert all(t == pytest.approx(0.25 * round(t / 0.25), abs=0.05) for t in cycles[1:])
    assert records[-1][0] == topics.APP_COUNTERS  # the final counters made it to the file
