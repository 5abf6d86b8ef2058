"""``ridsafe report``: the paper's tables from a sweep equal a recomputation from the logs; the
published table is transcribed consistently; the statistics are the textbook ones."""

from __future__ import annotations

import argparse
import csv
import json
import math
import shutil
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from ridsafe.tools.analysis.metrics import compute_metrics
from ridsafe.tools.analysis.plots import band, hold_on_grid
from ridsafe.tools.analysis.published import PUBLISHED
from ridsafe.tools.analysis.report import write_report
from ridsafe.tools.analysis.run_arrays import load_run
from ridsafe.tools.analysis.sweep_results import ROWS, Cell, Row, Stat, load_sweep, stat
from ridsafe.tools.cli import report_cmd
from ridsafe.tools.run.scenario import REPO_ROOT
from ridsafe.tools.sweep.config import SweepConfig
from ridsafe.tools.sweep.engines import LocalPoolEngine
from ridsafe.tools.sweep.folder import LOG_FILE, RESULT_FILE
from ridsafe.tools.sweep.plan import load_sweep_file, plan_sweep
from ridsafe.tools.sweep.runner import run_sweep

PAPER = REPO_ROOT / "configs" / "paper.yaml"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
COUNT_KEYS = ("total_nmac", "nmac_benign_benign", "nmac_benign_spoofer", "unsafe_violations")


@pytest.fixture(scope="module")
def sweep_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("sweep")
    base, _ = load_sweep_file(PAPER)
    plan = plan_sweep(base, SweepConfig(densities=(4, 8), seeds="0:2", duration_s=20.0), "paper")
    assert run_sweep(plan, out, LocalPoolEngine(workers=2)).completed == 8
    return out


def _read_csv(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle))


def _recompute(sweep: Path) -> dict[tuple[str, int, str], list[float]]:
    """(planner, density, metric) -> per-run values, straight from each log with
    ``compute_metrics`` (and the raised alerts for false alerts)."""
    values: dict[tuple[str, int, str], list[float]] = defaultdict(list)
    for log in sorted(sweep.rglob(LOG_FILE)):
        density_dir, planner, _seed = log.parent.relative_to(sweep).parts
        density = int(density_dir.removeprefix("n"))
        run = load_run(log)
        metrics: dict[str, float | int | None] = dict(compute_metrics(run))
        bb, bs = metrics["nmac_benign_benign"], metrics["nmac_benign_spoofer"]
        assert bb is not None and bs is not None
        metrics["total_nmac"] = bb + bs
        metrics["false_alerts"] = sum(
            1 for _, a in run.alerts if a["state"] == "raised" and a["uas_id"] != run.spoofer_serial
        )
        for key, value in metrics.items():
            if value is not None:
                values[(planner, density, key)].append(float(value))
    return values


# --------------------------------------------------------------------------------------------
# The published table and the statistics


def test_published_totals_are_the_sum_of_their_parts_and_counts_are_k_over_30() -> None:
    for planner in ("aware", "trust-rid"):
        for density in (4, 8, 12, 16):
            total = PUBLISHED[("total_nmac", planner)][density][0]
            bb = PUBLISHED[("nmac_benign_benign", planner)][density][0]
            bs = PUBLISHED[("nmac_benign_spoofer", planner)][density][0]
            assert total == pytest.approx(bb + bs, abs=0.0015)
    for (key, _planner), by_density in PUBLISHED.items():
        if key in COUNT_KEYS:
            for mean, _std in by_density.values():
                assert mean * 30 == pytest.approx(round(mean * 30), abs=0.02)


def test_published_values_quoted_in_the_design_notes() -> None:
    assert PUBLISHED[("nmac_benign_spoofer", "aware")][16] == (0.233, 0.568)
    assert PUBLISHED[("nmac_benign_spoofer", "trust-rid")][16] == (2.200, 0.805)
    assert PUBLISHED[("containment_rate", "aware")][16][0] == 0.839
    assert PUBLISHED[("rmse_m", "aware")][16][0] == 63.649
    assert PUBLISHED[("gcs_compute_s", "aware")][16] == (7.24, 1.11)
    assert ("unsafe_violations", "trust-rid") not in PUBLISHED  # the paper's "--"


def test_stat_is_the_papers_sample_std() -> None:
    s = stat([1.0] * 9 + [0.0] * 21)  # 9 of 30 runs: the paper's 0.300 +/- 0.466
    assert s is not None and (s.n, round(s.mean, 3), round(s.std, 3)) == (30, 0.3, 0.466)
    one = stat([2.0])
    assert one is not None and one.mean == 2.0 and math.isnan(one.std)
    assert stat([]) is None


def test_order_statistics_have_no_std() -> None:
    delays = [1.0, 2.0, 3.0, 4.0, 10.0]
    median, p90, worst = (stat(delays, summary) for summary in ("median", "p90", "max"))
    assert median is not None and (median.n, median.mean) == (5, 3.0) and math.isnan(median.std)
    assert p90 is not None and p90.mean == pytest.approx(7.6)  # linear between 4 and 10
    assert worst is not None and worst.mean == 10.0


def test_z_is_welchs_t_statistic() -> None:
    ours, published = Stat(8, 1.25, 0.9), Stat(30, 2.2, 0.805)
    cell = Cell(Row("x", "x", "s"), "aware", 16, "v", 8, ours, published)
    welch = stats.ttest_ind_from_stats(1.25, 0.9, 8, 2.2, 0.805, 30, equal_var=False)
    assert cell.diff == pytest.approx(1.25 - 2.2)
    assert cell.z == pytest.approx(welch.statistic, rel=1e-12)


def test_hold_on_grid_holds_the_last_sample_and_gaps_become_nan() -> None:
    t = np.array([0.0, 1.0, 3.0])
    y = np.array([10.0, 20.0, 30.0])
    grid = np.array([-0.5, 0.0, 0.5, 1.0, 2.0, 2.9, 3.0, 4.5])
    got = hold_on_grid(t, y, grid, max_gap_s=1.0)
    np.testing.assert_array_equal(got, [np.nan, 10, 10, 20, 20, np.nan, 30, np.nan])
    mean, low, high = band([np.array([1.0, np.nan, 3.0]), np.array([3.0, np.nan, np.nan])])
    np.testing.assert_array_equal(mean, [2.0, np.nan, 3.0])
    np.testing.assert_array_equal(low, [1.0, np.nan, 3.0])
    np.testing.assert_array_equal(high, [3.0, np.nan, 3.0])


# --------------------------------------------------------------------------------------------
# The report of a real sweep


@pytest.mark.slow
def test_the_report_equals_a_recomputation_from_the_logs(sweep_dir: Path, tmp_path: Path) -> None:
    files = write_report([sweep_dir], tmp_path, with_plots=False)
    rows = _read_csv(files.csv)
    expected = _recompute(sweep_dir)
    checked = 0
    for row in rows:
        values = expected.get((row["planner"], int(row["density"]), row["metric_key"]), [])
        assert int(row["runs"]) == 2
        if not values:
            assert row["n"] == "" and row["mean"] == ""
            continue
        assert int(row["n"]) == len(values)
        summary = row["summary"]
        if summary == "mean":
            assert float(row["mean"]) == pytest.approx(np.mean(values), rel=1e-12, abs=1e-12)
            if len(values) == 1:  # one run has the metric (a detection delay): no std
                assert row["std"] == ""
            else:
                std = np.std(values, ddof=1)
                assert float(row["std"]) == pytest.approx(std, rel=1e-9, abs=1e-12)
        else:  # an order statistic of the runs, no std
            order = {"median": np.median(values), "p90": np.quantile(values, 0.9)}
            assert float(row["mean"]) == pytest.approx(order.get(summary, max(values)), rel=1e-12)
            assert row["std"] == "" and row["published_mean"] == ""
        checked += 1
    assert checked >= len(ROWS) * 2 * 2 - 8  # nearly every (metric, planner, density) has data
    assert {(row["metric_key"], row["summary"]) for row in rows} == {
        (row.key, row.summary) for row in ROWS
    }


@pytest.mark.slow
def test_the_cache_is_used_only_while_it_matches_the_log(sweep_dir: Path, tmp_path: Path) -> None:
    copy = tmp_path / "sweep"
    shutil.copytree(sweep_dir, copy)
    result_path = copy / "n8/aware/seed001" / RESULT_FILE
    result = json.loads(result_path.read_text())
    truth = result["metrics"]["nmac_benign_benign"]
    result["metrics"]["nmac_benign_benign"] = truth + 100  # a cache that lies
    result_path.write_text(json.dumps(result))

    def cached_value(recompute: bool) -> object:
        sweep = load_sweep(copy, recompute)
        record = next(r for r in sweep.records if r.run_dir == result_path.parent)
        return record.metrics["nmac_benign_benign"]

    assert cached_value(False) == truth + 100  # the cache is trusted while its log matches
    assert cached_value(True) == truth  # --recompute reads the logs, and caches them again
    assert json.loads(result_path.read_text())["metrics"]["nmac_benign_benign"] == truth
    result = json.loads(result_path.read_text())
    result["log_size_bytes"] += 1  # the log is not the one the cache was computed from
    result_path.write_text(json.dumps(result))
    assert load_sweep(copy).from_logs == 1
    assert load_sweep(copy).from_logs == 0  # the cache was repaired
    result["run_digest"] = "0123456789abcdef"  # a result of another config: stale, skipped
    result_path.write_text(json.dumps(result))
    sweep = load_sweep(copy)
    assert (len(sweep.records), sweep.stale) == (7, 1)


@pytest.mark.slow
def test_caches_of_an_older_version_are_computed_again_on_every_worker_and_rewritten(
    sweep_dir: Path, tmp_path: Path
) -> None:
    """A metric key missing from every cache (a sweep flown before the metric existed): all
    eight runs come from their logs, on two processes, with progress, the same numbers as
    the caches had; the caches are rewritten, so the next load reads none."""
    copy = tmp_path / "sweep"
    shutil.copytree(sweep_dir, copy)
    before = {r.run_dir.relative_to(sweep_dir): r.metrics for r in load_sweep(sweep_dir).records}
    for result_path in copy.rglob(RESULT_FILE):
        result = json.loads(result_path.read_text())
        del result["metrics"]["region_delay_s"]
        result_path.write_text(json.dumps(result))
    calls: list[tuple[int, int]] = []
    sweep = load_sweep(copy, workers=2, progress=lambda done, total: calls.append((done, total)))
    assert sweep.from_logs == 8 and calls[-1] == (8, 8) and len(calls) == 8
    after = {r.run_dir.relative_to(copy): r.metrics for r in sweep.records}
    assert after == before  # every metric is a function of the log alone
    assert load_sweep(copy).from_logs == 0


@pytest.mark.slow
def test_report_files_side_by_side_and_the_command_line(
    sweep_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    twin = tmp_path / "twin"
    shutil.copytree(sweep_dir, twin)
    parser = argparse.ArgumentParser()
    report_cmd.register(parser.add_subparsers())
    out = tmp_path / "report"
    args = parser.parse_args(["report", str(sweep_dir), str(twin), "--out", str(out)])
    assert args.func(args) == 0
    printed = capsys.readouterr().out
    markdown = (out / "report.md").read_text()
    assert f"{twin.name}/paper" in markdown and f"{sweep_dir.name}/paper" in markdown
    expected = (
        "## Safety (paper Table 2)",
        "| Total NMACs | SA (aware) | published |",
        "0.100 ± 0.305",  # Table 2, SA benign-spoofer NMACs at 8 aircraft
        "| Unsafe violations | Trust-RID | " + f"{sweep_dir.name}/paper |",  # no published row
        "## Not reported by the paper",
        "False alerts",
        "| Detection delay, 90th percentile (s) | SA (aware) |",
        "## Table 2 by the paper's own definitions",
        "| Time-mean largest semi-axis (m) | SA (aware) | published |",
        "87.5 ± 2.3",  # Table 2's ellipsoid radius at 8 aircraft, beside the paper's definition
        "## Detectors (ROC from the logged statistics)",
        "| twin/paper | mlat |",
    )
    for text in expected:
        assert text in markdown, text
    assert "| 12 aircraft" not in markdown  # only the densities that were flown
    pngs = sorted(out.glob("*.png"))
    assert [p.name for p in pngs] == sorted(
        [
            f"fig3_{sweep_dir.name}_paper.png",
            "fig3_twin_paper.png",
            "nmac_vs_density.png",
            f"roc_{sweep_dir.name}_paper.png",
            "roc_twin_paper.png",
        ]
    )
    for png in pngs:
        assert png.read_bytes()[:8] == PNG_MAGIC and png.name in markdown
        assert str(png) in printed
    args = parser.parse_args(["report", str(tmp_path / "nothing")])
    assert args.func(args) == 2
    assert "not a sweep folder" in capsys.readouterr().err
