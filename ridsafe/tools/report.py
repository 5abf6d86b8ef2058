"""Reports of sweeps: the paper's Tables 2 and 3 from the run logs, the published values beside.

Input: one or more sweep folders (``ridsafe sweep``), e.g. our defaults and paper mode. Each
completed run's metrics are its ``result.json`` cache of :func:`ridsafe.tools.sweep.run_metrics`
(the log's metrics), recomputed from ``run.mcap`` when the cache does not match the log's size
or with ``recompute=True``. A result whose run digest differs from what the folder's
``scenario.yaml`` (the config of its latest sweep) gives for its spec is stale: skipped.

Every cell is the mean +/- sample std (ddof 1, as the paper: 0.300 +/- 0.466 is 9 of 30) over
the completed runs of one (sweep, parameter values, planner, density) that have the metric;
``(n=k)`` marks cells where fewer runs than completed have it. Beside each: the published value
(:data:`PUBLISHED`, 30 runs per cell), the difference ours - published and
``z = diff / sqrt(s^2/n + s_pub^2/30)`` (Welch's statistic: |z| > 2 is unlikely by chance).

Outputs: ``report.md`` (tables in the paper's layout: metrics x densities, planners in
blocks), ``report.csv`` (one row per cell), and the plots of :mod:`ridsafe.tools.plots`.
"""

from __future__ import annotations

import csv
import dataclasses
import itertools
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ridsafe.common.config import from_mapping, parse_yaml
from ridsafe.common.errors import RidsafeError
from ridsafe.tools.metrics import METRIC_KEYS
from ridsafe.tools.scenario import ScenarioFile
from ridsafe.tools.sweep import (
    LOG_FILE,
    MANIFEST_FILE,
    RESULT_FILE,
    SCENARIO_FILE,
    ParamValue,
    RunSpec,
    RunStatus,
    format_value,
    run_metrics,
    safe_run_digest,
)

__all__ = [
    "PUBLISHED",
    "PUBLISHED_RUNS",
    "ROWS",
    "Cell",
    "ReportError",
    "RunRecord",
    "Stat",
    "SweepResults",
    "load_sweep",
    "metric_value",
    "stat",
    "summarise",
    "write_report",
]

Published = Mapping[int, tuple[float, float]]  # density -> (mean, std)
Metrics = Mapping[str, float | int | None]

_SA, _RID = "aware", "trust-rid"  # the paper's "SA" and "RID" / "Trust-RID"
#: (metric, planner, (mean, std) at 4, 8, 12 and 16 aircraft), as published.
_PAPER_ROWS: tuple[
    tuple[
        str, str, tuple[float, float], tuple[float, float], tuple[float, float], tuple[float, float]
    ],
    ...,
] = (
    # Table 2 (tab:merged_clean), block "Safety Metrics (SA)", rows "Total NMACs",
    # "Benign--Benign", "Benign--Spoofer", "Unsafe violations"
    ("total_nmac", _SA, (0.300, 0.466), (1.733, 1.230), (4.067, 2.545), (7.000, 3.311)),
    ("nmac_benign_benign", _SA, (0.267, 0.450), (1.633, 1.273), (3.700, 2.409), (6.767, 3.245)),
    ("nmac_benign_spoofer", _SA, (0.033, 0.183), (0.100, 0.305), (0.367, 0.556), (0.233, 0.568)),
    ("unsafe_violations", _SA, (2.700, 3.669), (0.933, 1.230), (1.533, 2.177), (3.033, 2.965)),
    # Table 2, block "Safety Metrics (RID)", rows "Total NMACs", "Benign--Benign",
    # "Benign--Spoofer" (its "Unsafe violations" row is "--")
    ("total_nmac", _RID, (0.267, 0.450), (1.933, 1.507), (4.933, 1.929), (8.967, 3.264)),
    ("nmac_benign_benign", _RID, (0.267, 0.450), (1.200, 1.064), (3.533, 1.655), (6.767, 2.967)),
    ("nmac_benign_spoofer", _RID, (0.000, 0.000), (0.733, 0.691), (1.400, 0.814), (2.200, 0.805)),
    # Table 2, block "Localization Metrics (SA only)", rows "Containment rate", "RMSE (m)",
    # "MAE (m)", "Ellipsoid radius (m)"
    ("containment_rate", _SA, (0.478, 0.259), (0.804, 0.186), (0.894, 0.109), (0.839, 0.106)),
    ("rmse_m", _SA, (334.394, 434.679), (71.953, 32.075), (57.274, 22.065), (63.649, 15.694)),
    ("mae_m", _SA, (239.724, 308.027), (61.286, 26.111), (48.596, 16.370), (51.190, 11.357)),
    (
        "max_ellipsoid_radius_m",
        _SA,
        (81.687, 6.848),
        (87.534, 2.338),
        (87.334, 2.075),
        (87.885, 1.184),
    ),
    # Table 3 (tab:runtime_by_scenario_sa_rid), columns "Total wall-clock" SA and Trust-RID,
    # rows 4, 8, 12, 16
    ("wall_clock_s", _SA, (40.07, 3.70), (83.60, 21.94), (188.40, 48.08), (221.77, 39.36)),
    ("wall_clock_s", _RID, (31.53, 4.61), (82.57, 14.72), (153.70, 27.35), (108.23, 13.56)),
    # Table 3, columns "GCS compute" SA and Trust-RID, rows 4, 8, 12, 16
    ("gcs_compute_s", _SA, (5.42, 0.68), (4.66, 0.33), (6.27, 0.92), (7.24, 1.11)),
    ("gcs_compute_s", _RID, (0.14, 0.02), (0.36, 0.06), (0.58, 0.12), (0.39, 0.04)),
)
#: The paper's published values: (metric, planner) -> density -> (mean, std), 30 runs each.
PUBLISHED: Mapping[tuple[str, str], Published] = {
    (key, planner): dict(zip((4, 8, 12, 16), values, strict=True))
    for key, planner, *values in _PAPER_ROWS
}
PUBLISHED_RUNS = 30

PLANNER_LABELS: Mapping[str, str] = {"aware": "SA (aware)", "trust-rid": "Trust-RID"}
_PLANNER_ORDER = ("aware", "trust-rid")


@dataclass(frozen=True)
class Row:
    key: str  # a metric of run_metrics, or "total_nmac"
    label: str
    section: str
    digits: int = 3


SAFETY = "Safety (paper Table 2)"
LOCALISATION = "Localisation (paper Table 2; the paper reports SA only)"
COST = "Computation per run (paper Table 3; the paper ran OMNeT++ on 2 x 16 Xeon cores)"
EXTRA = "Not reported by the paper"
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
    Row("alert_time_s", "Detection time (s)", EXTRA, 2),
    Row("detection_delay_s", "Detection delay after 4 aircraft heard it (s)", EXTRA, 2),
    Row("false_alerts", "False alerts", EXTRA),
    Row("min_distance_to_spoofer_m", "Min distance to spoofer (m)", EXTRA, 1),
    Row("gcs_update_p99_ms", "GCS update p99 (ms)", EXTRA, 2),
    Row("planner_decision_p99_ms", "Planner decision p99 (ms)", EXTRA, 2),
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


def load_sweep(path: Path, recompute: bool = False, label: str | None = None) -> SweepResults:
    """Read a sweep folder (see the module docstring for where metrics come from)."""
    try:
        manifest = json.loads((path / MANIFEST_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        raise ReportError(f"{path}: not a sweep folder (no readable {MANIFEST_FILE})") from err
    base = _base(path)
    records: list[RunRecord] = []
    problems: list[tuple[str, str, str]] = []
    stale = from_logs = 0
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
            metrics, fresh = _metrics(run_dir, result, recompute)
            from_logs += fresh
            records.append(RunRecord(run_dir, spec, metrics))
    config = str(manifest.get("config"))
    return SweepResults(
        path,
        label or Path(config).name,
        config,
        tuple(records),
        tuple(problems),
        stale,
        from_logs,
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


def _metrics(run_dir: Path, result: Mapping[str, object], recompute: bool) -> tuple[Metrics, bool]:
    """(metrics, computed from the log now?): the cache when it matches the log."""
    log = run_dir / LOG_FILE
    cached = result.get("metrics")
    size = log.stat().st_size if log.exists() else None
    if (
        not recompute
        and isinstance(cached, dict)
        and all(key in cached for key in METRIC_KEYS)  # else a cache of an older version
        and size == result.get("log_size_bytes")
    ):
        return cached, False
    return run_metrics(log), True


# --------------------------------------------------------------------------------------------
# Statistics


@dataclass(frozen=True)
class Stat:
    n: int
    mean: float
    std: float  # sample std (ddof 1); NaN for one run


def stat(values: Sequence[float]) -> Stat | None:
    if not values:
        return None
    array = np.asarray(values, dtype=np.float64)
    std = float(array.std(ddof=1)) if array.size > 1 else math.nan
    return Stat(int(array.size), float(array.mean()), std)


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


def _published(key: str, planner: str, density: int) -> Stat | None:
    value = PUBLISHED.get((key, planner), {}).get(density)
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
        published = _published(row.key, planner, density)
        cells.append(Cell(row, planner, density, variant, len(group), stat(values), published))
    return cells


def planner_order(present: set[str]) -> list[str]:
    return [p for p in _PLANNER_ORDER if p in present] + sorted(present - set(_PLANNER_ORDER))


# --------------------------------------------------------------------------------------------
# Markdown and CSV


def _fmt(value: float | None, digits: int) -> str:
    return "n/a" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"


def _fmt_stat(s: Stat | None, digits: int, runs: int) -> str:
    if s is None:
        return "n/a"
    text = _fmt(s.mean, digits) + ("" if math.isnan(s.std) else f" ± {_fmt(s.std, digits)}")
    return text + (f" (n={s.n})" if s.n != runs else "")


def _fmt_diff(cell: Cell) -> str:
    if cell.diff is None:
        return "n/a"
    z = cell.z
    return f"{cell.diff:+.{cell.row.digits}f}" + ("" if z is None else f" (z {z:+.1f})")


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return lines + ["| " + " | ".join(row) + " |" for row in rows]


def _section_rows(cells: Sequence[Cell], section: str) -> list[list[str]]:
    """Rows of one section: per (metric, planner) the published values, then per variant
    ours and the difference; (metric, planner) pairs with no number anywhere are left out."""
    rows: list[list[str]] = []
    densities = sorted({c.density for c in cells})
    blocks: dict[tuple[str, str], list[Cell]] = {}
    for cell in cells:
        if cell.row.section == section:
            blocks.setdefault((cell.row.key, cell.planner), []).append(cell)
    for block in blocks.values():
        if all(c.ours is None and c.published is None for c in block):
            continue
        first = block[0]
        name = [first.row.label, PLANNER_LABELS.get(first.planner, first.planner)]
        by_variant: dict[str, dict[int, Cell]] = {}
        for cell in block:
            by_variant.setdefault(cell.variant, {})[cell.density] = cell
        any_variant = next(iter(by_variant.values()))
        if any(c.published is not None for c in block):
            published = [
                _fmt_stat(any_variant[d].published, first.row.digits, PUBLISHED_RUNS)
                if d in any_variant
                else "n/a"
                for d in densities
            ]
            rows.append([*name, "published", *published])
            name = ["", ""]
        for variant, by_density in by_variant.items():
            ours = [
                _fmt_stat(by_density[d].ours, first.row.digits, by_density[d].runs)
                for d in densities
            ]
            rows.append([*name, variant, *ours])
            name = ["", ""]
            if any(c.published is not None for c in by_density.values()):
                rows.append(
                    ["", "", f"Δ {variant}", *(_fmt_diff(by_density[d]) for d in densities)]
                )
    return rows


_SWEEP_HEADER = (
    "label",
    "folder",
    "config",
    "flight (s)",
    "completed",
    "not completed",
    "stale",
    "metrics from log",
)


def _sweep_row(s: SweepResults) -> list[str]:
    flights = ", ".join(f"{d:g}" for d in s.flights_s)
    counts = (len(s.records), len(s.problems), s.stale, s.from_logs)
    return [s.label, str(s.path), s.config, flights, *map(str, counts)]


def render_markdown(
    sweeps: Sequence[SweepResults], cells: Sequence[Cell], plots: Sequence[Path]
) -> str:
    densities = sorted({c.density for c in cells})
    lines = ["# Sweep report", ""]
    lines += _table(_SWEEP_HEADER, [_sweep_row(s) for s in sweeps])
    lines += [
        "",
        "Cells: mean ± sample std over completed runs ((n=k): only k of them have the metric). "
        f"published: the paper's value ({PUBLISHED_RUNS} runs per cell). Δ: ours - published, "
        "z = Δ / sqrt(s²/n + s_pub²/30) (|z| > 2: unlikely to be chance). n/a: no number. "
        "The published runs flew 120 s; stale: results of another config, ignored.",
    ]
    counts = _run_counts(cells, densities)
    header = ["Metric", "Planner", "Source", *(f"{d} aircraft" for d in densities)]
    lines += ["", "## Runs completed", "", *_table(header, counts)]
    for section in dict.fromkeys(row.section for row in ROWS):
        rows = _section_rows(cells, section)
        if rows:
            lines += ["", f"## {section}", "", *_table(header, rows)]
    if plots:
        lines += ["", "## Plots", ""] + [f"![{p.stem}]({p.name})" for p in plots]
    problems = [(s.label, *p) for s in sweeps for p in s.problems]
    if problems:
        lines += ["", "## Runs that did not complete", ""]
        lines += [f"- {label}: {run} {status}: {reason}" for label, run, status, reason in problems]
    return "\n".join(lines) + "\n"


def _run_counts(cells: Sequence[Cell], densities: Sequence[int]) -> list[list[str]]:
    first = ROWS[0].key
    table: dict[tuple[str, str], dict[int, int]] = {}
    for cell in cells:
        if cell.row.key == first:
            table.setdefault((cell.planner, cell.variant), {})[cell.density] = cell.runs
    return [
        [
            "runs",
            PLANNER_LABELS.get(planner, planner),
            variant,
            *(str(by_density.get(d, 0)) for d in densities),
        ]
        for (planner, variant), by_density in table.items()
    ]


CSV_HEADER = (
    "section",
    "metric",
    "metric_key",
    "planner",
    "density",
    "variant",
    "runs",
    "n",
    "mean",
    "std",
    "published_mean",
    "published_std",
    "diff",
    "z",
)


def _num(value: float | None) -> str:
    return "" if value is None or not math.isfinite(value) else repr(value)


def _csv_row(c: Cell) -> list[object]:
    ours = [] if c.ours is None else [c.ours.n, _num(c.ours.mean), _num(c.ours.std)]
    pub = [] if c.published is None else [_num(c.published.mean), _num(c.published.std)]
    head = [c.row.section, c.row.label, c.row.key, c.planner, c.density, c.variant, c.runs]
    return [*head, *(ours or ["", "", ""]), *(pub or ["", ""]), _num(c.diff), _num(c.z)]


def write_csv(cells: Sequence[Cell], path: Path) -> Path:
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(CSV_HEADER)
        writer.writerows(_csv_row(cell) for cell in cells)
    return path


# --------------------------------------------------------------------------------------------
# The report


@dataclass(frozen=True)
class ReportFiles:
    markdown: Path
    csv: Path
    plots: tuple[Path, ...]


def write_report(
    sweep_dirs: Sequence[Path],
    out: Path,
    *,
    recompute: bool = False,
    with_plots: bool = True,
    fig3_density: int = 16,
) -> ReportFiles:
    """Read the sweeps, write report.md, report.csv and the plots into ``out``."""
    sweeps = [load_sweep(path, recompute) for path in sweep_dirs]
    if len({s.label for s in sweeps}) != len(sweeps):  # one config twice: add the folder
        sweeps = [dataclasses.replace(s, label=f"{s.path.name}/{s.label}") for s in sweeps]
    if not any(s.records for s in sweeps):
        raise ReportError(f"no completed runs in {', '.join(map(str, sweep_dirs))}")
    out.mkdir(parents=True, exist_ok=True)
    cells = summarise(sweeps)
    plot_paths: list[Path] = []
    if with_plots:
        from ridsafe.tools.plots import report_plots  # noqa: PLC0415 (matplotlib only here)

        plot_paths = report_plots(sweeps, cells, out, fig3_density)
    markdown = out / "report.md"
    markdown.write_text(render_markdown(sweeps, cells, plot_paths), encoding="utf-8")
    return ReportFiles(markdown, write_csv(cells, out / "report.csv"), tuple(plot_paths))
