"""Sweeps: the matrix, its run folders, resume, failures, and the same metrics from the local
process pool and from a Dask local cluster."""

from __future__ import annotations

import argparse
import json
import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import pytest

from ridsafe.common.errors import ConfigError
from ridsafe.tools.cli import run_cmd, sweep_cmd
from ridsafe.tools.run.scenario import REPO_ROOT, ScenarioFile
from ridsafe.tools.sweep.config import ParamAxis, SweepConfig
from ridsafe.tools.sweep.engines import DaskEngine, LocalPoolEngine
from ridsafe.tools.sweep.folder import LOG_FILE, RESULT_FILE, RunOutcome, RunStatus, read_result
from ridsafe.tools.sweep.plan import (
    RunSpec,
    SweepError,
    SweepPlan,
    load_sweep_file,
    plan_sweep,
    scenario_for,
)
from ridsafe.tools.sweep.runner import run_sweep

PAPER = REPO_ROOT / "configs" / "paper.yaml"
#: Keys that measure this machine, not the run: they differ between identical runs.
TIMING_KEYS = {"wall_clock_s", "gcs_compute_s", "gcs_update_p99_ms", "planner_decision_p99_ms"}
#: The test matrix: 2 densities x 2 seeds x 2 planners, 20 s flights.
SMALL = SweepConfig(densities=(4, 8), seeds="0:2", duration_s=20.0)


def _cli(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    sweep_cmd.register(parser.add_subparsers())
    return parser.parse_args(["sweep", *argv])


def _plan(config: SweepConfig = SMALL, overrides: dict[str, object] | None = None) -> SweepPlan:
    base, _ = load_sweep_file(PAPER, overrides)
    return plan_sweep(base, config, str(PAPER))


@dataclass
class RecordingEngine:
    """Flies nothing: records which specs a sweep asks for."""

    name: str = "recording"
    workers: int = 1
    asked: list[RunSpec] = field(default_factory=list)

    def run(
        self, base: ScenarioFile, specs: Sequence[RunSpec], out_dir: Path
    ) -> Iterator[RunOutcome]:
        self.asked.extend(specs)
        return iter(())


# --------------------------------------------------------------------------------------------
# The matrix


def test_the_paper_config_without_a_sweep_section_is_the_papers_matrix() -> None:
    plan = _plan(SweepConfig())
    assert len(plan.specs) == 4 * 30 * 2
    assert {s.duration_s for s in plan.specs} == {120.0}
    assert len({s.run_dir for s in plan.specs}) == len(plan.specs)
    # seed-major: the first 8 runs are seed 0 at every density and planner, largest first
    assert {s.seed for s in plan.specs[:8]} == {0}
    assert [s.density for s in plan.specs[:8:2]] == [16, 12, 8, 4]
    assert str(plan.specs[0].run_dir) == "n16/aware/seed000"


def test_a_sweep_section_is_split_off_and_errors_name_its_key(tmp_path: Path) -> None:
    text = PAPER.read_text()
    good = tmp_path / "good.yaml"
    good.write_text(
        text + "\nsweep:\n  densities: [4]\n  seeds: [3, 5]\n  planners: [aware]\n"
        "  params:\n    alpha: {keys: [pipeline.region.alpha], values: [0.05, 0.1]}\n"
    )
    base, config = load_sweep_file(good)
    assert base == load_sweep_file(PAPER)[0]
    plan = plan_sweep(base, config, str(good))
    assert [str(s.run_dir) for s in plan.specs] == [
        "n4/aware/seed003/alpha=0.05",
        "n4/aware/seed003/alpha=0.1",
        "n4/aware/seed005/alpha=0.05",
        "n4/aware/seed005/alpha=0.1",
    ]
    assert scenario_for(base, plan.specs[1]).pipeline.region.alpha == 0.1
    bad = tmp_path / "bad.yaml"
    bad.write_text(text + "\nsweep:\n  planners: [aware, trust]\n")
    with pytest.raises(ConfigError, match=r"bad.yaml: sweep.planners\[1\]: unknown planner"):
        load_sweep_file(bad)


def test_a_spec_flies_what_ridsafe_run_flies_for_the_same_flags() -> None:
    """The same scenario; the sweep's logs leave the derived Foxglove channels out."""
    plan = _plan()
    spec = next(s for s in plan.specs if s.density == 8 and s.seed == 1)
    overrides = ["run.foxglove_channels=false"]
    args = argparse.Namespace(
        config=str(PAPER), overrides=overrides, seed=1, duration=20.0, aircraft=8, planner=None
    )
    assert scenario_for(plan.base, spec) == run_cmd.effective_scenario(args)


def test_foxglove_channels_are_left_out_of_sweep_logs_unless_asked_for() -> None:
    for flags, wanted in (((), False), (("--foxglove",), True)):
        args = _cli(str(PAPER), "--densities", "4", "--seeds", "0", "--planners", "aware", *flags)
        plan = sweep_cmd.make_plan(args)
        assert scenario_for(plan.base, plan.specs[0]).run.foxglove_channels is wanted


def test_vary_flags_parse_into_axes() -> None:
    name, axis = sweep_cmd.parse_vary("pipeline.region.alpha=0.01,0.05")
    assert (name, axis) == ("alpha", ParamAxis(("pipeline.region.alpha",), (0.01, 0.05)))
    keys = "scenario.radio.shadowing_sigma_db+pipeline.rssi_sigma_db"
    name, axis = sweep_cmd.parse_vary(f"rssi:{keys}=1.0,2.5")
    assert name == "rssi" and len(axis.keys) == 2 and axis.values == (1.0, 2.5)


def test_flags_override_the_matrix() -> None:
    args = _cli(str(PAPER), "--densities", "4,8", "--seeds", "0:2", "--planners", "aware")
    config = sweep_cmd.sweep_config(args, SweepConfig())
    assert (config.densities, config.seed_values, config.planners) == ((4, 8), (0, 1), ("aware",))
    assert len(sweep_cmd.make_plan(args).specs) == 4


def test_a_set_of_a_key_an_axis_sets_is_an_error_not_silently_lost() -> None:
    """``configs/adversaries.yaml`` sweeps ``family.adversaries.preset``: a ``--set`` of it
    would be overwritten in every run."""
    adversaries = REPO_ROOT / "configs" / "adversaries.yaml"
    args = _cli(str(adversaries), "--set", "family.adversaries.preset=mixed")
    with pytest.raises(ValueError, match=r"--set family.adversaries.preset: the sweep's axis "):
        sweep_cmd.make_plan(args)
    args = _cli(
        str(PAPER), "--set", "pipeline.region.alpha=0.1", "--vary", "pipeline.region.alpha=0.01"
    )
    with pytest.raises(ValueError, match=re.escape("--vary alpha:pipeline.region.alpha=V1,V2")):
        sweep_cmd.make_plan(args)
    # A --set of a key no axis sets still applies.
    args = _cli(str(adversaries), "--set", "planner.region_margin_m=40", "--seeds", "0")
    assert len(sweep_cmd.make_plan(args).specs) > 0


def test_dry_run_lists_the_full_matrix(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    args = _cli(str(PAPER), "--dry-run", "--out", str(tmp_path / "sweep"))
    assert args.func(args) == 0
    out = capsys.readouterr().out
    assert "240 runs (4 densities [4, 8, 12, 16] x 30 seeds x 2 planners), 120 s each" in out
    assert "0 of 240 runs finished" in out


def test_bad_flags_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    args = _cli(str(PAPER), "--planners", "aware,nope", "--dry-run")
    assert args.func(args) == 2
    assert "unknown planner 'nope'" in capsys.readouterr().err
    args = _cli(str(PAPER), "--vary", "pipeline.region.alpha=0.05,2.0", "--dry-run")
    assert args.func(args) == 2  # checked before anything flies
    assert "alpha" in capsys.readouterr().err


# --------------------------------------------------------------------------------------------
# Flying: the local pool and Dask give the same metrics; resume; failures


def _metrics_by_run(out: Path) -> dict[str, dict[str, object]]:
    found = {}
    for path in sorted(out.rglob(RESULT_FILE)):
        result = json.loads(path.read_text())
        assert result["status"] == "completed", result["reason"]
        assert (path.parent / LOG_FILE).stat().st_size == result["log_size_bytes"]
        metrics = {k: v for k, v in result["metrics"].items() if k not in TIMING_KEYS}
        found[str(path.parent.relative_to(out))] = metrics
    return found


@pytest.fixture(scope="module")
def pool_sweep(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("pool")
    summary = run_sweep(_plan(), out, LocalPoolEngine(workers=2))
    assert (summary.total, summary.completed, summary.failed) == (8, 8, ())
    return out


@pytest.mark.slow
def test_the_pool_and_a_dask_local_cluster_give_identical_metrics(
    pool_sweep: Path, tmp_path: Path
) -> None:
    summary = run_sweep(_plan(), tmp_path, DaskEngine(workers=2))
    assert (summary.completed, summary.failed) == (8, ())
    pool, dask = _metrics_by_run(pool_sweep), _metrics_by_run(tmp_path)
    assert len(pool) == 8 and pool == dask
    assert {json.loads((tmp_path / d / RESULT_FILE).read_text())["engine"] for d in dask} == {
        "dask"
    }
    # the scenarios differ from each other: a comparison of identical numbers would prove
    # nothing (the two planners may fly a 20 s scenario alike, before the spoofer matters)
    for planner in ("aware", "trust-rid"):
        runs = [m for run, m in pool.items() if f"/{planner}/" in run]
        assert len(runs) == 4 and len({json.dumps(m, sort_keys=True) for m in runs}) == 4


@pytest.mark.slow
def test_a_rerun_skips_finished_runs_and_flies_only_the_missing(pool_sweep: Path) -> None:
    mtimes = {p: p.stat().st_mtime_ns for p in pool_sweep.rglob(RESULT_FILE)}
    engine = RecordingEngine()
    summary = run_sweep(_plan(), pool_sweep, engine)
    assert (summary.skipped, summary.completed, engine.asked) == (8, 0, [])
    assert {p: p.stat().st_mtime_ns for p in pool_sweep.rglob(RESULT_FILE)} == mtimes
    # an unfinished run (no result, or a failed one) is flown again
    victim = next(iter(mtimes))
    result = read_result(victim.parent)
    assert result is not None
    victim.write_text(json.dumps({**result, "status": "failed"}))
    summary = run_sweep(_plan(), pool_sweep, engine)
    assert summary.skipped == 7 and [str(s.run_dir) for s in engine.asked] == [
        str(victim.parent.relative_to(pool_sweep))
    ]
    victim.write_text(json.dumps(result))


@pytest.mark.slow
def test_a_config_edit_reflies_only_the_runs_it_changes(pool_sweep: Path) -> None:
    plan = _plan()
    # the family redraws the aircraft: the file's own aircraft do not matter
    scenario = replace(plan.base.scenario, aircraft=plan.base.scenario.aircraft[:1])
    engine = RecordingEngine()
    run_sweep(replace(plan, base=replace(plan.base, scenario=scenario)), pool_sweep, engine)
    assert engine.asked == []
    run_sweep(_plan(overrides={"pipeline.region.alpha": 0.1}), pool_sweep, engine)
    assert len(engine.asked) == 8
    run_sweep(_plan(), pool_sweep, engine)  # the manifest's base back as it was


@pytest.mark.slow
def test_a_folder_of_another_scenario_is_refused(pool_sweep: Path) -> None:
    other = _plan(overrides={"scenario.name": "paper-mode"})
    with pytest.raises(SweepError, match="holds a sweep of scenario 'paper'"):
        run_sweep(other, pool_sweep, RecordingEngine())


@pytest.mark.slow
def test_a_failing_run_is_recorded_and_the_rest_are_kept(tmp_path: Path) -> None:
    # alpha = 2 passes the matrix but fails in the worker (a run that raises)
    axis = ParamAxis(("pipeline.region.alpha",), (0.05, 2.0))
    config = replace(SMALL, densities=(4,), seeds="0", planners=("aware",), duration_s=2.0)
    plan = _plan(replace(config, params={"alpha": axis}))
    summary = run_sweep(plan, tmp_path, LocalPoolEngine(workers=2))
    assert summary.completed == 1 and len(summary.failed) == 1
    bad = summary.failed[0]
    assert bad.status is RunStatus.FAILED and "alpha" in bad.reason
    assert str(bad.spec.run_dir) == "n4/aware/seed000/alpha=2.0"
    result = read_result(tmp_path / bad.spec.run_dir)
    assert result is not None and result["status"] == "failed" and "alpha" in result["reason"]
    good = read_result(tmp_path / "n4/aware/seed000/alpha=0.05")
    assert good is not None and good["status"] == "completed" and good["sim_time_s"] == 2.0


@pytest.mark.slow
def test_the_command_line_flies_reports_a_summary_and_resumes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = [str(PAPER), "--densities", "4", "--seeds", "0", "--planners", "trust-rid"]
    argv += ["--duration", "3", "--workers", "1", "--no-progress", "--out", str(tmp_path)]
    args = _cli(*argv)
    assert args.func(args) == 0
    out = capsys.readouterr().out
    assert "1 runs: 0 already done, 1 completed, 0 failed" in out
    assert (tmp_path / "n4/trust-rid/seed000" / LOG_FILE).exists()
    assert args.func(args) == 0
    assert "1 runs: 1 already done, 0 completed" in capsys.readouterr().out
