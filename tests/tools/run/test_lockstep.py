"""End to end in lockstep: the default scenario flies, logs every channel, repeats exactly."""

from __future__ import annotations

import dataclasses
import gc
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from ridsafe.common import topics
from ridsafe.tools.analysis.metrics import compute_metrics
from ridsafe.tools.run.lockstep import run_lockstep
from ridsafe.tools.run.scenario import ScenarioFile, load_scenario_file
from ridsafe.tools.runlog.reader import read_records
from tests.signals import keyboard_interrupt_on_sigint
from tests.tools.run.output_watch import FLYING, OutputWatch

ROOT = Path(__file__).resolve().parents[3]
TIMING_KEYS = {"wall_clock_s", "gcs_compute_s", "gcs_update_p99_ms", "planner_decision_p99_ms"}


def _default(duration_s: float | None = None) -> ScenarioFile:
    loaded = load_scenario_file()
    if duration_s is not None:
        scenario = dataclasses.replace(loaded.scenario, duration_s=duration_s)
        loaded = dataclasses.replace(loaded, scenario=scenario)
    return loaded


@pytest.fixture(scope="module")
def default_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("lockstep") / "run.mcap"
    result = run_lockstep(_default(), "straight-line", out)
    assert result.status == "completed" and result.sim_time_s == pytest.approx(120.0)
    return out


def test_every_benign_aircraft_reaches_its_goal(default_run: Path) -> None:
    metrics = compute_metrics(default_run)
    assert metrics["goal_reached_fraction"] == 1.0


def test_the_log_contains_every_channel(default_run: Path) -> None:
    seen = {topic for topic, _, _ in read_records(default_run)}
    expected = {
        topics.RUN_META,
        topics.RUN_END,
        topics.TRUTH,
        topics.RADIO_TX,
        topics.RADIO_RX,
        topics.OBSERVATIONS,
        topics.DECISIONS,
        topics.COMPANION_EVENTS,
        topics.ALERTS,
        topics.TRACKS,
        topics.REGIONS,
        topics.GCS_CYCLE,
        topics.DETECTOR_STATS,
        topics.APP_COUNTERS,
    }
    assert expected <= seen, expected - seen
    assert {"/foxglove/aircraft", "/foxglove/unsafe_regions", "/foxglove/tf"} <= seen


def test_the_gcs_logs_that_it_kept_the_configured_channel(default_run: Path) -> None:
    """The default scenario's radio is the GCS's configured channel: the test on the
    cooperative aircraft keeps it, once, before the first alert."""
    records = list(read_records(default_run, topics=(topics.GCS_CHANNEL, topics.ALERTS)))
    (decision,) = [(t, r) for topic, t, r in records if topic == topics.GCS_CHANNEL]
    t_s, record = decision
    assert record["channel"] == "configured" and record["p_value"] >= 0.05
    assert record["exponent"] is None and 0.8 < record["residual_std_db"] < 1.2
    first_alert_s = min(t for topic, t, _ in records if topic == topics.ALERTS)
    assert t_s <= first_alert_s
    assert t_s <= 5.0  # 4 aircraft: 30 labelled receptions by 4.75 s (README)


def test_the_spoofer_is_heard_reported_detected_and_tracked(default_run: Path) -> None:
    records = list(read_records(default_run))
    meta = next(r for t, _, r in records if t == topics.RUN_META)
    serial = meta["spoofer"]["serial"]
    reported = {
        item["uas_id"] for t, _, r in records if t == topics.OBSERVATIONS for item in r["items"]
    }
    assert serial in reported
    assert any(t == topics.ALERTS and r["uas_id"] == serial for t, _, r in records)
    assert any(t == topics.REGIONS and r["uas_id"] == serial for t, _, r in records)
    counters = [r for t, _, r in records if t == topics.APP_COUNTERS and r["app"] == "gcs"]
    assert counters and counters[-1]["counters"].get("link_rejected_signature", 0) == 0


def test_the_same_seed_gives_the_same_metrics_and_log_content(tmp_path: Path) -> None:
    """Also whichever process writes the log: a child (the default) or the run's own."""
    loaded = _default(duration_s=30.0)
    logs = [tmp_path / f"{k}.mcap" for k in range(2)]
    for log, recorder_process in zip(logs, (True, False), strict=True):
        run_lockstep(loaded, "straight-line", log, recorder_process=recorder_process)
    first, second = (compute_metrics(log) for log in logs)
    assert {k: v for k, v in first.items() if k not in TIMING_KEYS} == {
        k: v for k, v in second.items() if k not in TIMING_KEYS
    }

    def content(log: Path) -> list[tuple[str, float, object]]:
        timing = (topics.GCS_CYCLE, topics.DECISIONS, topics.RUN_META, topics.RUN_END)
        return [(t, s, r) for t, s, r in read_records(log) if t not in timing]

    assert content(logs[0]) == content(logs[1])


def test_the_flight_runs_with_its_startup_objects_frozen_and_gives_them_back(
    tmp_path: Path,
) -> None:
    """Full collections skip what was built before t = 0, and a sweep worker's next run
    can collect this one's garbage cycles (nothing stays frozen)."""
    frozen_in_flight: list[int] = []
    loaded = _default(duration_s=2.0)
    run_lockstep(
        loaded,
        "straight-line",
        tmp_path / "run.mcap",
        on_progress=lambda _now_s: frozen_in_flight.append(gc.get_freeze_count()),
        recorder_process=False,
    )
    assert min(frozen_in_flight) > 10_000  # the modules and the cores, at least
    assert gc.get_freeze_count() == 0


def test_ctrl_c_ends_the_run_and_its_recorder_with_a_valid_log(tmp_path: Path) -> None:
    """The terminal sends SIGINT to the whole process group: the run and the recorder's
    child process. The run stops, logs how it ended, and nothing is left running."""
    out = tmp_path / "out"
    argv = [sys.executable, "-m", "ridsafe.tools.cli", "run", "--mode", "lockstep"]
    argv += ["--out", str(out), "--aircraft", "16", "--duration", "600"]
    with keyboard_interrupt_on_sigint():  # the child gets Ctrl-C however pytest was started
        proc = subprocess.Popen(
            argv, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
            start_new_session=True,
        )  # fmt: skip
    watch = OutputWatch(proc)
    watch.wait_for(FLYING, timeout_s=240.0)  # kernels compiled or loaded, the clock running
    os.killpg(proc.pid, signal.SIGINT)
    output = watch.finish(timeout_s=60)
    assert proc.returncode == 1, output
    records = list(read_records(out / "run.mcap"))
    (end,) = [r for t, _, r in records if t == topics.RUN_END]
    assert end["status"] == "interrupted" and 0.0 < end["sim_time_s"] < 600.0
    assert any(t == topics.TRUTH for t, _, _ in records)
    pgrep = ["pgrep", "-f", str(out)]
    leftovers = subprocess.run(pgrep, capture_output=True, text=True, check=False)
    assert leftovers.stdout.strip() == ""
