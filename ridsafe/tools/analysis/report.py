"""Reports of sweeps: the paper's Tables 2 and 3 from the run logs, the published values beside.

Input: one or more sweep folders (``ridsafe sweep``), e.g. our defaults and paper mode, read by
``analysis.sweep_results`` (which results count, and how a cell is computed). Outputs:
``report.md`` (tables in the paper's layout: metrics x densities, planners in blocks; ``(n=k)``
marks cells where fewer runs than completed have the metric; with the plots, the detectors'
ROC AUC and operating point per sweep variant, ``analysis.detector_roc``, read from every
run's log; where the aware planner's benign-spoofer NMACs happened, ``analysis.nmac_report``,
read from the logs of the runs that had one), ``report.csv`` (one row per
cell; ``summary``: mean, median, p90 or max over the runs), and the plots of
:mod:`ridsafe.tools.analysis.plots`.
"""

from __future__ import annotations

import csv
import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from ridsafe.tools.analysis.adversary_report import adversary_section
from ridsafe.tools.analysis.channel_report import channel_section
from ridsafe.tools.analysis.detector_roc import DetectorRoc, detector_rocs, roc_rows
from ridsafe.tools.analysis.nmac_report import nmac_section
from ridsafe.tools.analysis.published import PUBLISHED_RUNS
from ridsafe.tools.analysis.sweep_results import (
    PLANNER_LABELS,
    ROWS,
    Cell,
    Progress,
    ReportError,
    Row,
    Stat,
    SweepResults,
    format_number,
    load_sweep,
    summarise,
)
from ridsafe.tools.sweep.folder import LOG_FILE

__all__ = ["CSV_HEADER", "ReportFiles", "render_markdown", "write_csv", "write_report"]


# --------------------------------------------------------------------------------------------
# Markdown and CSV


def _fmt_stat(s: Stat | None, digits: int, runs: int) -> str:
    if s is None:
        return "n/a"
    text = format_number(s.mean, digits) + (
        "" if math.isnan(s.std) else f" ± {format_number(s.std, digits)}"
    )
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
    blocks: dict[tuple[Row, str], list[Cell]] = {}
    for cell in cells:
        if cell.row.section == section:
            blocks.setdefault((cell.row, cell.planner), []).append(cell)
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
    sweeps: Sequence[SweepResults],
    cells: Sequence[Cell],
    plots: Sequence[Path],
    rocs: Mapping[str, Sequence[DetectorRoc]] | None = None,
) -> str:
    densities = sorted({c.density for c in cells})
    lines = ["# Sweep report", ""]
    lines += _table(_SWEEP_HEADER, [_sweep_row(s) for s in sweeps])
    lines += [
        "",
        "Cells: mean ± sample std over completed runs ((n=k): only k of them have the metric), "
        "or, where the metric says so, the runs' median, 90th percentile or worst value. "
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
    lines += adversary_section(sweeps)  # issue 16's attack cells, if the sweep has them
    lines += channel_section(sweeps)  # issue 15's channel settings, if a sweep is one
    lines += nmac_section(sweeps)  # the aware planner's NMACs, from the logs of those runs
    rows = [
        row for label, variant_rocs in (rocs or {}).items() for row in roc_rows(label, variant_rocs)
    ]
    if rows:
        lines += ["", "## Detectors (ROC from the logged statistics)", ""]
        lines += [
            "Every claim each detector tested, in every run of the variant (both planners): a "
            "liar's claim (a serial no benign aircraft has) flagged is a true positive, a "
            "benign aircraft's a false positive. AUC: P(a liar's statistic > a benign one's). "
            "Operating point: the rates of the logged decisions (the thresholds the GCS used).",
            "",
        ]
        roc_header = ("variant", "detector", "claims (liars / benign)", "AUC", "TPR", "FPR")
        lines += _table(roc_header, rows)
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
    "summary",
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
    row = c.row
    head = [row.section, row.label, row.key, row.summary, c.planner, c.density, c.variant, c.runs]
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
    workers: int = 1,
    progress: Progress | None = None,
) -> ReportFiles:
    """Read the sweeps, write report.md, report.csv and the plots into ``out``; metrics read
    from the logs are computed on ``workers`` processes (``progress``: ``load_sweep``'s)."""
    sweeps = [
        load_sweep(path, recompute, workers=workers, progress=progress) for path in sweep_dirs
    ]
    if len({s.label for s in sweeps}) != len(sweeps):  # one config twice: add the folder
        sweeps = [dataclasses.replace(s, label=f"{s.path.name}/{s.label}") for s in sweeps]
    if not any(s.records for s in sweeps):
        raise ReportError(f"no completed runs in {', '.join(map(str, sweep_dirs))}")
    out.mkdir(parents=True, exist_ok=True)
    cells = summarise(sweeps)
    rocs: dict[str, list[DetectorRoc]] = {}
    plot_paths: list[Path] = []
    if with_plots:  # the ROC reads every run's log: with the plots, not from the cache alone
        rocs = {
            label: detector_rocs(r.run_dir / LOG_FILE for r in sweep.records if r.params == params)
            for sweep in sweeps
            for params, label in sweep.variants()
        }
        from ridsafe.tools.analysis.plots import report_plots  # noqa: PLC0415 (matplotlib only here)

        plot_paths = report_plots(sweeps, cells, out, fig3_density, rocs)
    markdown = out / "report.md"
    markdown.write_text(render_markdown(sweeps, cells, plot_paths, rocs), encoding="utf-8")
    return ReportFiles(markdown, write_csv(cells, out / "report.csv"), tuple(plot_paths))
