"""A live run's processes start with every compiled kernel ready and their heap frozen, or say
how late they were."""

from __future__ import annotations

import gc
import json
import logging
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from ridsafe.common import topics
from ridsafe.tools.run import process
from ridsafe.tools.runlog.reader import read_records

ROOT = Path(__file__).resolve().parents[3]

#: Build the cores as each process of a live run builds its own before the start instant, then
#: fly 30 s of the default scenario in the same process (past the alert, so tracking and
#: regions run); prints every ridsafe kernel's compiled signatures after each.
BUILD_THEN_RUN = """
import dataclasses, gc, json, sys
from pathlib import Path
from numba.core.dispatcher import Dispatcher
from ridsafe.common.logsink import NullSink
from ridsafe.tools.run.lockstep import build, run_lockstep
from ridsafe.tools.run.scenario import load_scenario_file

def compiled():
    gc.unfreeze()  # a run freezes its start-up objects, the kernels among them
    return {
        f"{d.py_func.__module__}.{d.py_func.__qualname__}": sorted(map(str, d.signatures))
        for d in gc.get_objects()
        if isinstance(d, Dispatcher) and d.py_func.__module__.startswith("ridsafe.")
    }

loaded = load_scenario_file()
build(loaded, "aware", NullSink())
after_build = compiled()
scenario = dataclasses.replace(loaded.scenario, duration_s=30.0)
loaded = dataclasses.replace(loaded, scenario=scenario)
run_lockstep(loaded, "aware", Path(sys.argv[1]), recorder_process=False, split=False)
print(json.dumps({"after_build": after_build, "after_run": compiled()}))
"""


@pytest.mark.slow
def test_built_cores_have_every_kernel_a_run_calls(tmp_path: Path) -> None:
    """Building the sim, the companions and the GCS loads (or compiles) every kernel
    signature their run calls: a live run's processes build their cores before the start
    instant, so none stands still after it while numba loads a kernel (the sim's once did,
    for 0.4 s of a slow host's wall clock), and ``warm_up`` (the same build and a tick)
    leaves every one of them in numba's cache after an install. Checked on the kernels'
    signatures in one process, whatever the cache held: numba caches one entry per kernel
    and signature."""
    log = tmp_path / "run.mcap"
    done = subprocess.run(
        [sys.executable, "-c", BUILD_THEN_RUN, str(log)],
        check=False, cwd=ROOT, capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    compiled = json.loads(done.stdout.splitlines()[-1])
    after_build, after_run = compiled["after_build"], compiled["after_run"]
    # The kernels called from Python (the ones they call are compiled into them, and are
    # listed with their own signatures only when compiled here, not loaded from the cache).
    assert sum(1 for s in after_build.values() if s) >= 15
    for package in ("ridsafe.sim_backend.", "ridsafe.companion.", "ridsafe.gcs."):
        assert any(name.startswith(package) and s for name, s in after_build.items())
    alerts = list(read_records(log, {topics.ALERTS}))
    assert alerts, "the run never alerted: tracking and regions did not run"
    new = {
        name: sorted(set(s) - set(after_build.get(name, [])))
        for name, s in after_run.items()
        if set(s) - set(after_build.get(name, []))
    }
    assert new == {}


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
