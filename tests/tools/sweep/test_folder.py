"""A sweep's folder (``sweep.folder``): what a run leaves, what counts as finished, and a
folder of another scenario refused."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from ridsafe.tools.run.scenario import REPO_ROOT
from ridsafe.tools.sweep.config import SweepConfig
from ridsafe.tools.sweep.folder import (
    LOG_FILE,
    MANIFEST_FILE,
    RESULT_FILE,
    RUN_LOG_FILE,
    SCENARIO_FILE,
    RunOutcome,
    RunStatus,
    is_finished,
    prepare_folder,
    read_result,
    record_outcome,
)
from ridsafe.tools.sweep.plan import SweepError, SweepPlan, load_sweep_file, plan_sweep

PAPER = REPO_ROOT / "configs" / "paper.yaml"


def _plan(overrides: dict[str, object] | None = None) -> SweepPlan:
    base, _ = load_sweep_file(PAPER, overrides)
    return plan_sweep(base, SweepConfig(densities=(4,), seeds="0:2", planners=("aware",)))


def _outcome(plan: SweepPlan, status: RunStatus, log: bytes | None) -> RunOutcome:
    return RunOutcome(
        plan.specs[0], status, "", {"nmac_benign_benign": 1}, 2.5, 120.0, "host:1",
        ("WARNING x: one",), log,
    )  # fmt: skip


def test_a_completed_run_leaves_its_log_result_and_warnings(tmp_path: Path) -> None:
    plan = _plan()
    run_dir = record_outcome(tmp_path, plan, _outcome(plan, RunStatus.COMPLETED, b"MCAP"), "pool")
    assert run_dir == tmp_path / "n4" / "aware" / "seed000"
    assert (run_dir / LOG_FILE).read_bytes() == b"MCAP"
    assert (run_dir / RUN_LOG_FILE).read_text() == "WARNING x: one\n"
    result = read_result(run_dir)
    assert result is not None
    assert result["status"] == "completed" and result["engine"] == "pool"
    assert result["run_digest"] == plan.digests[plan.specs[0]] != ""
    assert result["log_size_bytes"] == 4 and result["warnings"] == 1
    assert result["spec"] == plan.specs[0].to_json()
    assert not list(run_dir.glob(".*.tmp"))  # written atomically
    assert is_finished(run_dir, plan.digests[plan.specs[0]])


def test_what_does_not_count_as_finished(tmp_path: Path) -> None:
    plan = _plan()
    digest = plan.digests[plan.specs[0]]
    failed = record_outcome(tmp_path / "a", plan, _outcome(plan, RunStatus.FAILED, b"M"), "pool")
    assert not is_finished(failed, digest)
    done = record_outcome(tmp_path / "b", plan, _outcome(plan, RunStatus.COMPLETED, b"M"), "pool")
    assert not is_finished(done, "another digest")  # a config edit changed this run
    assert not is_finished(done, "")  # a spec whose scenario cannot be built
    (done / LOG_FILE).unlink()
    assert not is_finished(done, digest)  # no log, no result
    (done / RESULT_FILE).write_text("{not json")
    assert read_result(done) is None
    assert read_result(tmp_path / "nowhere") is None


def test_the_folder_holds_one_scenario(tmp_path: Path) -> None:
    plan = _plan()
    prepare_folder(tmp_path, plan, "pool", 2)
    manifest = json.loads((tmp_path / MANIFEST_FILE).read_text())
    assert (manifest["engine"], manifest["workers"], manifest["runs"]) == ("pool", 2, 2)
    assert (tmp_path / SCENARIO_FILE).exists()
    prepare_folder(tmp_path, _plan({"pipeline.region.alpha": 0.1}), "dask", 4)  # same name
    other = _plan({"scenario.name": "elsewhere"})
    with pytest.raises(SweepError, match="holds a sweep of scenario"):
        prepare_folder(tmp_path, other, "pool", 2)
