"""A live run's processes start with every compiled kernel ready and their heap frozen, or say
how late they were."""

from __future__ import annotations

import gc
import json
import logging
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from ridsafe.tools.run import process

ROOT = Path(__file__).resolve().parents[3]

WARM_UP = """
from ridsafe.tools.run.lockstep import warm_up
from ridsafe.tools.run.scenario import load_scenario_file
print(warm_up(load_scenario_file(), "aware"))
"""


def _cache_files(cache: Path) -> set[str]:
    return {p.name for p in cache.rglob("*.nbc")}


@pytest.mark.slow
def test_after_warm_up_a_run_compiles_nothing_new(tmp_path: Path) -> None:
    """In an empty numba cache (as after an install), warm_up fills it with every kernel a
    run uses: a run afterwards (past the alert, so tracking and regions run) adds none."""
    cache = tmp_path / "numba-cache"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    warm = subprocess.run(
        [sys.executable, "-c", WARM_UP],
        check=False, cwd=ROOT, env=env, capture_output=True, text=True,
    )  # fmt: skip
    assert warm.returncode == 0, warm.stderr
    assert float(warm.stdout) > 0.0
    after_warm_up = _cache_files(cache)
    assert len(after_warm_up) >= 40  # sim, planner and GCS kernels, each with its signatures
    run = subprocess.run(
        [sys.executable, "-m", "ridsafe.tools.cli", "run", "--mode", "lockstep",
         "--duration", "30", "--out", str(tmp_path / "out")],
        check=False, cwd=ROOT, env=env, capture_output=True, text=True,
    )  # fmt: skip
    assert run.returncode == 0, run.stdout + run.stderr
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["metrics"]["alert_time_s"] is not None
    assert _cache_files(cache) == after_warm_up


@pytest.fixture(autouse=True)
def _unfreeze() -> Iterator[None]:
    """wait_for_start freezes the heap of the process calling it: here, pytest's."""
    yield
    gc.unfreeze()


def test_a_process_ready_late_says_which_and_how_much_it_missed(
    caplog: pytest.LogCaptureFixture,
) -> None:
    with caplog.at_level(logging.WARNING, logger="ridsafe.tools.run.process"):
        process.wait_for_start(time.time() - 3.0, 4.0, "companion 1-4")
    (message,) = [r.getMessage() for r in caplog.records]
    assert message.startswith("companion 1-4: ready 3.0 s (wall) after")
    assert "first 12.0 s of sim time" in message  # 3 s late at 4x


def test_a_process_ready_in_time_waits_for_the_start_and_says_nothing(
    caplog: pytest.LogCaptureFixture,
) -> None:
    t0 = time.time() + 0.2
    with caplog.at_level(logging.WARNING, logger="ridsafe.tools.run.process"):
        process.wait_for_start(t0, 1.0, "sim")
    assert time.time() >= t0
    assert not caplog.records


def test_what_was_built_before_the_start_is_out_of_the_collectors_reach() -> None:
    built = [{"core": k} for k in range(10_000)]  # stands for the kernels and the core
    process.wait_for_start(time.time(), 1.0, "gcs")
    assert gc.get_freeze_count() >= len(built)  # a full collection no longer walks them
