"""Sweep results: the completed runs of sweep folders, their statistics and the report's cells.

Shared by the report (``analysis.report``: tables) and the plots (``analysis.plots``).

Each completed run's metrics are its ``result.json`` cache of
:func:`ridsafe.tools.sweep.folder.run_metrics` (the log's metrics), recomputed from
``run.mcap`` when the cache does not match the log's size or this version's metric keys, or
with ``recompute=True`` (on every core, the cache then rewritten with them). A
result whose run digest differs from what the folder's ``scenario.yaml`` (the config of its
latest sweep) gives for its spec is stale: skipped.

Every cell is the mean +/- sample std (ddof 1, as the paper: 0.300 +/- 0.466 is 9 of 30) over
the completed runs of one (sweep, parameter values, planner, density) that have the metric;
beside it the published value (``analysis.published``), the difference ours - published and
``z = diff / sqrt(s^2/n + s_pub^2/30)`` (Welch's statistic: |z| > 2 is unlikely by chance).
A row may instead summarise the runs by their median, 90th percentile or worst value (the
detection delay's distribution); such a cell has no std and no published value.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from ridsafe.common.config import from_mapping, parse_yaml
from ridsafe.common.errors import RidsafeError
from ridsafe.tools.analysis.metrics import METRIC_KEYS
from ridsafe.tools.analysis.published import PUBLISHED, PUBLISHED_RUNS
from ridsafe.tools.run.scenario import ScenarioFile
from ridsafe.tools.sweep.config import ParamValue, format_value
from ridsafe.tools.sweep.engines import metrics_of_logs
from ridsafe.tools.sweep.folder import (
    LOG_FILE,
    MANIFEST_FILE,
    RESULT_FILE,
    SCENARIO_FILE,
    RunStatus,
    refresh_metrics,
)
from ridsafe.tools.sweep.plan import RunSpec, safe_run_digest

__all__ = [
    "PLANNER_LABELS",
    "ROWS",
    "Cell",
    "ReportError",
    "Row",
    "RunRecord",
    "Stat",
    "Summary",
    "SweepResults",
    "format_number",
    "load_sweep",
    "mean_metric",
    "metric_value",
    "planner_order",
    "stat",
    "summarise",
]

Metrics = Mapping[str, float | int | None]
#: ``progress(done, total)``: how many of the runs whose metrics come from their logs are done.
Progress = Callable[[int, int], None]

PLANNER_LABELS: Mapping[str, str] = {"aware": "SA (aware)", "trust-rid": "Trust-RID"}
_PLANNER_ORDER = ("aware", "trust-rid")


#: How a cell summarises its runs: mean +/- sample std, or one order statistic.
Summary = Literal["mean", "median", "p90", "max"]


@dataclass(frozen=True)
class Row:
    key: str  # a metric of run_metrics, or "total_nmac"
    label: str
    section: str
    digits: int = 3
    summary: Summary = "mean"
    # the published row this one is compared with (default: key); only for summary "mean"
    published_key: str | None = None


SAFETY = "Safety (paper Table 2)"
LOCALISATION = "Localisation (paper Table 2; the paper reports SA only)"
COST = "Computation per run (paper Table 3; the paper ran OMNeT++ on 2 x 16 Xeon cores)"
EXTRA = "Not reported by the paper"
PAPER_DEFINITIONS = (
    "Table 2 by the paper's own definitions (analysis/paper_metrics.py: 0.25 s ticks, arrived "
    "aircraft excluded, the published region's centre, the time-mean largest semi-axis)"
)
ROWS: tuple[Row, ...] = (
    Row("total_nmac", "Total NMACs", SAFETY),
    Row("nmac_benign_benign", "Benign-benign NMACs", SAFETY),
    Row("nmac_benign_spoofer", "Benign-spoofer NMACs", SAFETY),
    Row("unsafe_violations", "Unsafe violations", SAFETY),
    Row("containment_rate", "Containment rate", LOCALISATION),
    Row("rmse_m", "RMSE (m)", LOCALISATION),
    Row("mae_m", "MAE (m)", LOCALISATION),
    Row("max_ellipsoid_radius_m", "Max ellipsoid radius (m)", LOCALISATION),
    Row("wall_clock_s", "Wall clock (s)", COST, 2),
    Row("gcs_compute_s", "GCS compute (s)", COST, 2),
    Row("goal_reached_fraction", "Goal reached (fraction)", EXTRA),
    Row("landed_fraction", "Landed on the site (fraction)", EXTRA),
    Row("alert_time_s", "Detection time (s)", EXTRA, 2),
    Row("detection_delay_s", "Detection delay after 4 aircraft heard it (s)", EXTRA, 2),
    Row("detection_delay_s", "Detection delay, median (s)", EXTRA, 2, "median"),
    Row("detection_delay_s", "Detection delay, 90th percentile (s)", EXTRA, 2, "p90"),
    Row("detection_delay_s", "Detection delay, worst (s)", EXTRA, 2, "max"),
    Row("region_delay_s", "First unsafe region after the alert (s)", EXTRA, 2),
    Row("region_delay_s", "First unsafe region after the alert, worst (s)", EXTRA, 2, "max"),
    Row("false_alerts", "False alerts", EXTRA),
    Row("false_alerts_per_aircraft_hour", "False alerts per aircraft-hour", EXTRA, 2),
    Row("min_distance_to_spoofer_m", "Min distance to spoofer (m)", EXTRA, 1),
    Row("gcs_update_p99_ms", "GCS update p99 (ms)", EXTRA, 2),
    Row("planner_decision_p99_ms", "Planner decision p99 (ms)", EXTRA, 2),
    *(
        Row(f"paper_{key}", label, PAPER_DEFINITIONS, digits, published_key=published)
        # published: the row of Table 2 it is compared with (the horizontal extent has none)
        for key, label, digits, published in (
            ("nmac_benign_benign", "Benign-benign NMACs", 3, "nmac_benign_benign"),
            ("nmac_benign_spoofer", "Benign-spoofer NMACs", 3, "nmac_benign_spoofer"),
            ("unsafe_violations", "Unsafe violations", 3, "unsafe_violations"),
            ("containment_rate", "Containment rate", 3, "containment_rate"),
            ("rmse_m", "RMSE of the region centre (m)", 1, "rmse_m"),
            ("mae_m", "MAE of the region centre (m)", 1, "mae_m"),
            (
                "mean_ellipsoid_radius_m",
                "Time-mean largest semi-axis (m)",
                1,
                "max_ellipsoid_radius_m",
            ),
            (
                "mean_horizontal_radius_m",
                "... of the horizontal extent (m; not in the paper)",
                1,
                None,
            ),
        )
    ),
)


class ReportError(RidsafeError):
    """A folder is not a sweep folder, or holds nothing to report."""


# --------------------------------------------------------------------------------------------
# Reading sweeps


@dataclass(frozen=True)
class RunRecord:
    """One completed run and its metrics."""

    run_dir: Path
    spec: RunSpec
    metrics: Metrics

    @property
    def density(self) -> int:
        return self.spec.density

    @property
    def planner(self) -> str:
        return self.spec.planner

    @property
    def params(self) -> tuple[tuple[str, ParamValue], ...]:
        return self.spec.params


@dataclass(frozen=True)
class SweepResults:
    path: Path
    label: str
    config: str
    records: tuple[RunRecord, ...]
    problems: tuple[tuple[str, str, str], ...]  # (run dir, status, last line of the reason)
    stale: int  # results of another config, skipped
    from_logs: int  # runs whose metrics were computed from run.mcap now
    #: its config's GCS always fits the channel (``pipeline.calibration.enabled: true``; not
    #: ``auto``, which keeps the configured one while it fits)
    calibrating: bool = False

    @property
    def flights_s(self) -> tuple[float, ...]:
        """The flight durations of the completed runs."""
        return tuple(sorted({r.spec.duration_s for r in self.records}))

    def variants(self) -> list[tuple[tuple[tuple[str, ParamValue], ...], str]]:
        """(params, label) of each parameter combination present, in first-seen order."""
        seen: dict[tuple[tuple[str, ParamValue], ...], str] = {}
        for record in self.records:
            if record.params not in seen:
                values = ", ".join(f"{k}={format_value(v)}" for k, v in record.params)
                seen[record.params] = f"{self.label} [{values}]" if values else self.label
        return list(seen.items())


def load_sweep(
    path: Path,
    recompute: bool = False,
    label: str | None = None,
    *,
    workers: int = 1,
    progress: Progress | None = None,
) -> SweepResults:
    """Read a sweep folder (see the module docstring for where metrics come from). Metrics
    computed from the logs are computed on ``workers`` processes, ``progress(done, total)``
    told after each, and written back to each run's result.json cache."""
    try:
        manifest = json.loads((path / MANIFEST_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        raise ReportError(f"{path}: not a sweep folder (no readable {MANIFEST_FILE})") from err
    base = _base(path)
    records: list[RunRecord] = []
    problems: list[tuple[str, str, str]] = []
    stale = 0
    stale_cache: list[int] = []  # records whose metrics come from their log
    for result_path in sorted(path.rglob(RESULT_FILE)):
        run_dir = result_path.parent
        name = str(run_dir.relative_to(path))
        result = json.loads(result_path.read_text(encoding="utf-8"))
        status = str(result.get("status"))
        spec = RunSpec.from_json(result["spec"])
        if result.get("run_digest") != safe_run_digest(base, spec):
            stale += 1
        elif status != RunStatus.COMPLETED.value:
            problems.append((name, status, _last_line(str(result.get("reason")))))
        elif not (run_dir / LOG_FILE).exists():
            problems.append((name, status, f"but its {LOG_FILE} is missing"))
        else:
            cached = None if recompute else _cached_metrics(run_dir, result)
            records.append(RunRecord(run_dir, spec, cached or {}))
            if cached is None:
                stale_cache.append(len(records) - 1)
    logs = [records[k].run_dir / LOG_FILE for k in stale_cache]
    for k, metrics in zip(stale_cache, metrics_of_logs(logs, workers, progress), strict=True):
        records[k] = dataclasses.replace(records[k], metrics=metrics)
        refresh_metrics(records[k].run_dir, metrics)
    from_logs = len(stale_cache)
    config = str(manifest.get("config"))
    return SweepResults(
        path,
        label or Path(config).name,
        config,
        tuple(records),
        tuple(problems),
        stale,
        from_logs,
        base.pipeline.calibration.enabled is True,
    )


def _last_line(text: str) -> str:
    lines = text.strip().splitlines()
    return lines[-1] if lines else ""


def _base(path: Path) -> ScenarioFile:
    source = str(path / SCENARIO_FILE)
    try:
        text = (path / SCENARIO_FILE).read_text(encoding="utf-8")
    except OSError as err:
        raise ReportError(f"{path}: not a sweep folder (no readable {SCENARIO_FILE})") from err
    return from_mapping(ScenarioFile, parse_yaml(text, source), source)


def _cached_metrics(run_dir: Path, result: Mapping[str, object]) -> Metrics | None:
    """The result's metrics cache while it matches the log (its size) and this version's
    metrics (every key); None: compute them from the log."""
    log = run_dir / LOG_FILE
    cached = result.get("metrics")
    size = log.stat().st_size if log.exists() else None
    if (
        isinstance(cached, dict)
        and all(key in cached for key in METRIC_KEYS)  # else a cache of an older version
        and size == result.get("log_size_bytes")
    ):
        return cached
    return None


# --------------------------------------------------------------------------------------------
# Statistics


@dataclass(frozen=True)
class Stat:
    n: int
    mean: float
    std: float  # sample std (ddof 1); NaN for one run


def stat(values: Sequence[float], summary: Summary = "mean") -> Stat | None:
    """The runs' values summarised: mean and sample std, or an order statistic (std NaN)."""
    if not values:
        return None
    array = np.asarray(values, dtype=np.float64)
    if summary != "mean":
        quantile = {"median": 0.5, "p90": 0.9, "max": 1.0}[summary]
        return Stat(int(array.size), float(np.quantile(array, quantile)), math.nan)
    std = float(array.std(ddof=1)) if array.size > 1 else math.nan
    return Stat(int(array.size), float(array.mean()), std)


def format_number(value: float | None, digits: int = 2) -> str:
    """A report cell: the value to ``digits`` decimals, "n/a" when missing or not finite."""
    return "n/a" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"


def mean_metric(records: Sequence[RunRecord], key: str) -> float | None:
    """The mean of ``key`` over the records that have a finite value of it; None if none."""
    values = [r.metrics.get(key) for r in records]
    known = [float(v) for v in values if isinstance(v, int | float) and math.isfinite(v)]
    return float(np.mean(known)) if known else None


def metric_value(metrics: Metrics, key: str) -> float | None:
    """A metric of one run; ``total_nmac`` = benign-benign + benign-spoofer (the paper's)."""
    if key == "total_nmac":
        bb, bs = metrics.get("nmac_benign_benign"), metrics.get("nmac_benign_spoofer")
        return None if bb is None else float(bb) + float(bs or 0)
    value = metrics.get(key)
    return None if value is None else float(value)


@dataclass(frozen=True)
class Cell:
    """One (row, planner, density, variant): ours, published, difference."""

    row: Row
    planner: str
    density: int
    variant: str
    runs: int  # completed runs of this (variant, planner, density)
    ours: Stat | None
    published: Stat | None

    @property
    def diff(self) -> float | None:
        if self.ours is None or self.published is None:
            return None
        return self.ours.mean - self.published.mean

    @property
    def z(self) -> float | None:
        if self.ours is None or self.published is None or self.ours.n < 2:
            return None
        var = self.ours.std**2 / self.ours.n + self.published.std**2 / self.published.n
        return None if var <= 0.0 else (self.ours.mean - self.published.mean) / math.sqrt(var)


def _published(row: Row, planner: str, density: int) -> Stat | None:
    if row.summary != "mean":
        return None
    value = PUBLISHED.get((row.published_key or row.key, planner), {}).get(density)
    return None if value is None else Stat(PUBLISHED_RUNS, value[0], value[1])


def summarise(sweeps: Sequence[SweepResults]) -> list[Cell]:
    """Every cell of the report, in row, planner, variant, density order."""
    groups: dict[tuple[str, str, int], list[RunRecord]] = {}
    for sweep in sweeps:
        labels = dict(sweep.variants())
        for r in sweep.records:
            groups.setdefault((labels[r.params], r.planner, r.density), []).append(r)
    variants = list(dict.fromkeys(variant for variant, _, _ in groups))
    planners = planner_order({planner for _, planner, _ in groups})
    densities = sorted({density for _, _, density in groups})
    cells = []
    for row, planner, variant, density in itertools.product(ROWS, planners, variants, densities):
        group = groups.get((variant, planner, density), [])
        values = [v for r in group if (v := metric_value(r.metrics, row.key)) is not None]
        published = _published(row, planner, density)
        ours = stat(values, row.summary)
        cells.append(Cell(row, planner, density, variant, len(group), ours, published))
    return cells


def planner_order(present: set[str]) -> list[str]:
    return [p for p in _PLANNER_ORDER if p in present] + sorted(present - set(_PLANNER_ORDER))
