"""End to end in live mode: separate processes over real UDP, Ctrl-C, a crashed child."""

from __future__ import annotations

import itertools
import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from ridsafe.common import topics
from ridsafe.tools.cli import run_cmd
from ridsafe.tools.run import live
from ridsafe.tools.runlog.reader import read_records
from tests.signals import keyboard_interrupt_on_sigint
from tests.tools.run.live_runs import start_live_run
from tests.tools.run.output_watch import OutputWatch, wait_for_text

# Below the kernel's ephemeral range, as test_live_spray's: a port-0 socket can't take them.
PORTS = [
    "--set", "sim.ports.companion_base=29760",
    "--set", "sim.ports.gcs_out_base=29550",
    "--set", "run.gcs_listen=udpin:127.0.0.1:29450",
]  # fmt: skip


def _run(out: Path, *extra: str) -> subprocess.Popen[str]:
    return start_live_run(out, *PORTS, *extra)


@pytest.mark.udp
def test_a_short_fast_live_run_flies_logs_and_reports(tmp_path: Path) -> None:
    proc = _run(tmp_path / "out", "--speed", "6", "--duration", "40")
    output, _ = proc.communicate(timeout=120)
    assert proc.returncode == 0, output
    assert run_cmd.KERNELS_NOTICE + "ready in" in output
    child_logs = "".join(p.read_text() for p in (tmp_path / "out" / "logs").glob("*.log"))
    assert "after the run's start instant" not in child_logs  # every process was in time
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["status"] == "completed"
    records = list(read_records(tmp_path / "out" / "run.mcap"))
    counts: dict[str, int] = {}
    for topic, _, _ in records:
        counts[topic] = counts.get(topic, 0) + 1
    assert counts[topics.TRUTH] >= 380  # 10 Hz over 40 s, from the sim process
    assert counts[topics.GCS_CYCLE] >= 150  # 4 Hz, from the GCS process
    assert counts[topics.OBSERVATIONS] > 50  # from the companions' process
    assert counts[topics.RUN_META] == counts[topics.RUN_END] == 1
    times = [t for _, t, _ in records]
    assert all(b >= a - 1e-6 for a, b in itertools.pairwise(times))  # merged in order
    airborne = [
        r for t, _, r in records if t == topics.TRUTH and max(p[2] for p in r["p_enu_m"][:4]) > 10
    ]
    assert airborne, "no benign aircraft took off"
    gcs = [r for t, _, r in records if t == topics.APP_COUNTERS and r["app"] == "gcs"]
    assert gcs[-1]["counters"]["observations_accepted"] > 50
    assert gcs[-1]["counters"].get("link_rejected_signature", 0) == 0  # signed and accepted


@pytest.mark.udp
def test_ctrl_c_stops_every_process_and_leaves_a_valid_log(tmp_path: Path) -> None:
    proc = _run(tmp_path / "out", "--speed", "2", "--duration", "600")
    watch = OutputWatch(proc)
    # the sim is flying (its first status line, at 5 sim s), so its log part has records
    wait_for_text(tmp_path / "out" / "logs" / "sim.log", " armed ", timeout_s=240.0)
    proc.send_signal(signal.SIGINT)
    output = watch.finish(timeout_s=60)
    assert proc.returncode == 1, output
    records = list(read_records(tmp_path / "out" / "run.mcap"))
    end = [r for t, _, r in records if t == topics.RUN_END]
    assert end and end[0]["status"] == "interrupted"
    assert any(t == topics.TRUTH for t, _, _ in records)
    leftovers = subprocess.run(
        ["pgrep", "-f", str(tmp_path / "out")], capture_output=True, text=True, check=False
    )
    assert leftovers.stdout.strip() == ""  # no child left running


def test_a_crashed_child_stops_the_run_with_its_name_and_log(tmp_path: Path) -> None:
    crash = "import sys, time; print('boom: cannot bind'); sys.exit(3)"
    children = [
        live.Child("steady", [sys.executable, "-c", "import time; time.sleep(60)"],
                   tmp_path / "a.log"),
        live.Child("fragile", [sys.executable, "-c", crash], tmp_path / "b.log"),
    ]  # fmt: skip
    started = time.monotonic()
    with keyboard_interrupt_on_sigint():  # the steady child stops on the SIGINT sent to it
        outcome = live.supervise(children, duration_s=60.0, speed=1.0, t0_unix=time.time())
    assert time.monotonic() - started < 20.0  # not a hang
    assert outcome.status == "failed"
    assert "fragile exited with code 3" in outcome.reason and "boom" in outcome.reason
    assert all(c.returncode is not None for c in children)  # the steady one was stopped


def test_children_that_ignore_sigint_are_stopped_without_its_grace(tmp_path: Path) -> None:
    """Started as a shell's background job, the run and its children ignore SIGINT: stopping
    them must not wait out ``STOP_GRACE_S`` for a signal nobody hears."""
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        sleeper = [sys.executable, "-c", "import time; time.sleep(60)"]
        child = live.Child("deaf", sleeper, tmp_path / "deaf.log")
        child.start()  # inherits SIGINT ignored
        time.sleep(0.5)  # its interpreter is up
        started = time.monotonic()
        live.stop([child])
        took_s = time.monotonic() - started
    finally:
        signal.signal(signal.SIGINT, previous)
    assert child.returncode == -signal.SIGTERM
    assert took_s < live.STOP_GRACE_S / 2
