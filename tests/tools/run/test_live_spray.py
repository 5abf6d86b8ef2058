"""A live run over real UDP while a hostile local process sprays the apps' ports with
garbage and with mutated MAVLink (CRC recomputed) built from a lockstep run's datagrams: the
run completes, the aircraft fly, no companion loses its autopilot and the GCS still takes
the companions' reports (issue 14)."""

from __future__ import annotations

import random
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from ridsafe.common import topics
from ridsafe.common.udp import UdpEndpoint
from ridsafe.tools.fuzz.harness import warm_up
from ridsafe.tools.fuzz.mutate import Mutator
from ridsafe.tools.run.scenario import load_scenario_file
from ridsafe.tools.runlog.reader import read_records
from tests.tools.run.test_live import ROOT

COMPANION_BASE, GCS_OUT_BASE, GCS_PORT = 36760, 36550, 36450  # apart from test_live's
COMPANION_PORTS = [COMPANION_BASE + 10 * k for k in range(4)]
# The spray starts once the sim reports every aircraft airborne (the companions have locked
# their ports). Earlier, a sprayer that sends MAVLink with a companion's ids before the
# companion itself would be locked as the sim port's peer: without signing on that link
# nothing tells them apart (see common/peer_lock.py).


def _run(out: Path, *extra: str) -> subprocess.Popen[str]:
    argv = [sys.executable, "-m", "ridsafe.tools.cli", "run", "--mode", "live", "--out", str(out)]
    ports = [
        "--set", f"sim.ports.companion_base={COMPANION_BASE}",
        "--set", f"sim.ports.gcs_out_base={GCS_OUT_BASE}",
        "--set", f"run.gcs_listen=udpin:127.0.0.1:{GCS_PORT}",
    ]  # fmt: skip
    return subprocess.Popen(
        [*argv, "--planner", "straight-line", *ports, *extra],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )


def _wait_until_flying(sim_log: Path, stop: threading.Event) -> None:
    while not stop.is_set():
        if sim_log.exists() and "airborne 5" in sim_log.read_text(errors="replace"):
            return
        stop.wait(0.1)


def _spray(stop: threading.Event, seeds: list[bytes], sent: list[int], sim_log: Path) -> None:
    rng = random.Random(14)
    mutator = Mutator(rng)
    _wait_until_flying(sim_log, stop)
    with UdpEndpoint() as sock:
        while not stop.is_set():
            for port in (*COMPANION_PORTS, GCS_PORT):
                for _ in range(5):
                    if rng.random() < 0.5:
                        data = rng.randbytes(rng.randint(1, 280))
                    else:
                        data = mutator.mutate(rng.choice(seeds), rng.choice(seeds))
                    sock.send(data, ("127.0.0.1", port))
                    sent[0] += 1
            stop.wait(0.002)


@pytest.mark.udp
def test_a_live_run_sprayed_with_garbage_and_mutated_mavlink_completes_and_flies(
    tmp_path: Path,
) -> None:
    paused = warm_up(load_scenario_file(None, {"scenario.duration_s": 10.0}), "aware", 4.0)
    seeds = [data for datagrams in paused.seeds.values() for _, data in datagrams]
    stop, sent = threading.Event(), [0]
    proc = _run(tmp_path / "out", "--speed", "2", "--duration", "50")
    sim_log = tmp_path / "out" / "logs" / "sim.log"
    sprayer = threading.Thread(target=_spray, args=(stop, seeds, sent, sim_log), daemon=True)
    sprayer.start()
    try:
        output, _ = proc.communicate(timeout=150)
    finally:
        stop.set()
        sprayer.join(timeout=5)
    assert proc.returncode == 0, output
    assert sent[0] > 20_000
    records = list(read_records(tmp_path / "out" / "run.mcap"))
    airborne = [
        r for t, _, r in records if t == topics.TRUTH and max(p[2] for p in r["p_enu_m"][:4]) > 10
    ]
    assert airborne, "no benign aircraft took off"
    counters = {r["app"]: r["counters"] for t, _, r in records if t == topics.APP_COUNTERS}
    companions = [c for app, c in counters.items() if app.startswith("companion/")]
    assert len(companions) == 4
    assert all(c["companion.autopilot_lost"] == 0 for c in companions)
    assert all(c["companion.handler_errors"] == 0 for c in companions)
    assert counters["gcs"]["observations_accepted"] > 50
    assert counters["gcs"]["handler_errors"] == 0
