"""PNG plots of a sweep: the paper's Fig. 3 and NMACs against traffic density.

matplotlib's object API with the Agg canvas (``Figure.savefig``): no pyplot, no global backend,
no display needed.

- :func:`fig3`: minimum distance to the spoofer, containment rate and localisation error over
  time (mean line, min-max band across runs), one colour per planner, the NMAC threshold
  dashed; as the paper's Fig. 3 ("Performance metrics over time for the scenario with 16
  agents").
- :func:`nmac_vs_density`: total and benign-spoofer NMACs (mean +/- std) against density,
  ours and the published values.
- :func:`detector_roc_plot`: each detector's ROC curve (``analysis.detector_roc``), its AUC
  and the logged decisions' operating point, false positive rate on a log axis.
- :func:`report_plots`: all three, for ``ridsafe report``.

Each run's series is resampled onto a common grid by holding its last sample (no value more
than ``max_gap_s`` old; NaN before a run's first sample, e.g. before the alert).
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from numpy.typing import NDArray

from ridsafe.tools.analysis.detector_roc import DetectorRoc
from ridsafe.tools.analysis.series import MetricSeries, metric_series
from ridsafe.tools.analysis.sweep_results import PLANNER_LABELS, Cell, SweepResults, planner_order
from ridsafe.tools.sweep.folder import LOG_FILE

__all__ = [
    "DensityCurve",
    "band",
    "density_curves",
    "detector_roc_plot",
    "fig3",
    "hold_on_grid",
    "nmac_vs_density",
    "report_plots",
]

FloatArray = NDArray[np.float64]
LineStyle = str | tuple[int, tuple[int, ...]]

GRID_STEP_S = 0.5
MAX_GAP_S = 1.0
_COLOURS = ("tab:blue", "tab:red", "tab:green", "tab:purple", "tab:orange", "tab:brown")


def hold_on_grid(
    t_s: FloatArray, y: FloatArray, grid_s: FloatArray, max_gap_s: float = MAX_GAP_S
) -> FloatArray:
    """``y`` (sampled at increasing ``t_s``) at each grid time: the last sample at or before
    it, NaN when there is none within ``max_gap_s``."""
    out = np.full(grid_s.shape, np.nan)
    if t_s.size == 0:
        return out
    index = np.searchsorted(t_s, grid_s, side="right") - 1
    valid = index >= 0
    safe = np.clip(index, 0, t_s.size - 1)
    valid &= grid_s - t_s[safe] <= max_gap_s
    out[valid] = y[safe[valid]]
    return out


def band(curves: Sequence[FloatArray]) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(mean, min, max) across curves (K, G) ignoring NaN; NaN where no curve has a value."""
    stack = np.vstack(curves) if curves else np.full((1, 0), np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN columns: NaN is the answer
        return np.nanmean(stack, axis=0), np.nanmin(stack, axis=0), np.nanmax(stack, axis=0)


def _panel(ax: Axes, grid: FloatArray, curves_by_label: Mapping[str, Sequence[FloatArray]]) -> None:
    for k, (label, curves) in enumerate(curves_by_label.items()):
        if not curves:
            continue
        mean, low, high = band(curves)
        colour = _COLOURS[k % len(_COLOURS)]
        ax.fill_between(grid, low, high, color=colour, alpha=0.2, linewidth=0)
        ax.plot(grid, mean, color=colour, label=f"{label} (n={len(curves)})")


def fig3(series: Mapping[str, Sequence[MetricSeries]], path: Path, title: str) -> Path:
    """The paper's Fig. 3 from ``metric_series`` of each run, grouped by planner label."""
    all_series = [s for runs in series.values() for s in runs]
    end_s = max((float(s.t_s[-1]) for s in all_series if s.t_s.size), default=0.0)
    grid = np.arange(0.0, end_s + GRID_STEP_S / 2, GRID_STEP_S)
    distance = {
        label: [hold_on_grid(s.t_s, s.min_distance_to_spoofer_m, grid) for s in runs]
        for label, runs in series.items()
    }
    containment = {
        label: [hold_on_grid(s.region_t_s, s.containment_rate, grid) for s in runs]
        for label, runs in series.items()
    }
    error = {
        label: [hold_on_grid(s.track_t_s, s.localisation_error_m, grid) for s in runs]
        for label, runs in series.items()
    }
    fig = Figure(figsize=(15.0, 4.2), layout="constrained")
    axes = fig.subplots(1, 3)
    for ax, curves, ylabel in zip(
        axes,
        (distance, containment, error),
        ("min distance to spoofer (m)", "containment rate", "localisation error (m)"),
        strict=True,
    ):
        _panel(ax, grid, curves)
        ax.set_xlabel("time (s)")
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
    threshold = next((s.nmac_threshold_m for s in all_series), 50.0)
    axes[0].axhline(threshold, color="black", linestyle="--", linewidth=1, label="NMAC threshold")
    axes[1].set_ylim(-0.02, 1.02)
    for ax in axes:
        ax.legend(loc="best", fontsize="small")
    fig.suptitle(title)
    fig.savefig(path, dpi=110)
    return path


@dataclass(frozen=True)
class DensityCurve:
    """Mean and std of one metric against density; ``published`` curves are drawn dashed."""

    label: str
    densities: tuple[int, ...]
    mean: tuple[float, ...]
    std: tuple[float, ...]
    published: bool = False  # drawn with square markers
    colour: str = ""  # matplotlib colour; "" picks one by position
    linestyle: LineStyle = "-"


def nmac_vs_density(panels: Mapping[str, Sequence[DensityCurve]], path: Path) -> Path:
    """One panel per metric title (e.g. total, benign-spoofer), curves with std error bars."""
    fig = Figure(figsize=(6.0 * max(len(panels), 1), 4.5), layout="constrained")
    axes = fig.subplots(1, max(len(panels), 1), squeeze=False)[0]
    for ax, (title, curves) in zip(axes, panels.items(), strict=False):
        for k, curve in enumerate(curves):
            offset = 0.12 * (k - (len(curves) - 1) / 2)  # keep error bars apart
            ax.errorbar(
                np.asarray(curve.densities, dtype=np.float64) + offset,
                curve.mean,
                yerr=curve.std,
                label=curve.label,
                color=curve.colour or _COLOURS[k % len(_COLOURS)],
                linestyle=curve.linestyle,
                marker="s" if curve.published else "o",
                capsize=3,
            )
        ax.set_title(title)
        ax.set_xlabel("benign aircraft")
        ax.set_ylabel("NMACs per run")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper left", fontsize="small")
    fig.savefig(path, dpi=110)
    return path


#: The false positive rate axis starts here (log scale; a rate of 0 is drawn at it).
ROC_FPR_FLOOR = 1e-5


def detector_roc_plot(rocs: Sequence[DetectorRoc], path: Path, title: str) -> Path:
    """Each detector's ROC curve (FPR on a log axis) with its AUC; a marker at the operating
    point of the logged decisions; the chance line dotted."""
    fig = Figure(figsize=(6.5, 5.0), layout="constrained")
    ax = fig.add_subplot()
    for k, roc in enumerate(rocs):
        colour = _COLOURS[k % len(_COLOURS)]
        fpr = np.maximum(roc.false_positive_rate, ROC_FPR_FLOOR)
        ax.step(
            fpr,
            roc.true_positive_rate,
            where="post",
            color=colour,
            label=f"{roc.detector} (AUC {roc.auc:.3f})",
        )
        ax.plot(max(roc.operating_fpr, ROC_FPR_FLOOR), roc.operating_tpr, "o", color=colour)
    chance = np.logspace(np.log10(ROC_FPR_FLOOR), 0.0, 50)
    ax.plot(chance, chance, ":", color="grey", label="chance")
    ax.set_xscale("log")
    ax.set_xlim(ROC_FPR_FLOOR, 1.0)
    ax.set_ylim(0.0, 1.01)
    ax.set_xlabel(f"false positive rate (benign claims flagged; {ROC_FPR_FLOOR:g} = none)")
    ax.set_ylabel("true positive rate (liars' claims flagged)")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="lower right", fontsize="small")
    fig.savefig(path, dpi=110)
    return path


# --------------------------------------------------------------------------------------------
# The report's plots


_PLANNER_COLOURS = {"aware": "tab:blue", "trust-rid": "tab:red"}
_VARIANT_STYLES = ("-", ":", "-.", (0, (5, 1)))


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.=-]+", "_", text).strip("_")


def report_plots(
    sweeps: Sequence[SweepResults],
    cells: Sequence[Cell],
    out: Path,
    fig3_density: int = 16,
    rocs: Mapping[str, Sequence[DetectorRoc]] | None = None,
) -> list[Path]:
    """Fig. 3 per sweep variant (at ``fig3_density`` aircraft, else the largest density it
    has), from ``metric_series`` of each run's log; NMACs against density from ``cells``;
    the detectors' ROC per variant label of ``rocs``."""
    paths = []
    for sweep in sweeps:
        for params, label in sweep.variants():
            runs = [r for r in sweep.records if r.params == params]
            have = {r.density for r in runs}
            density = fig3_density if fig3_density in have else max(have)
            series = {
                PLANNER_LABELS.get(planner, planner): [
                    metric_series(r.run_dir / LOG_FILE)
                    for r in runs
                    if r.planner == planner and r.density == density
                ]
                for planner in planner_order({r.planner for r in runs})
            }
            title = f"{label}: {density} aircraft (mean, min-max band across seeds)"
            paths.append(fig3(series, out / f"fig3_{_slug(label)}.png", title))
    panels = {
        "Total NMACs": density_curves(cells, "total_nmac"),
        "Benign-spoofer NMACs": density_curves(cells, "nmac_benign_spoofer"),
    }
    paths.append(nmac_vs_density(panels, out / "nmac_vs_density.png"))
    for label, variant_rocs in (rocs or {}).items():
        if variant_rocs:
            title = f"{label}: detectors, every claim of every run"
            paths.append(detector_roc_plot(variant_rocs, out / f"roc_{_slug(label)}.png", title))
    return paths


def density_curves(cells: Sequence[Cell], key: str) -> list[DensityCurve]:
    """Per planner: the published curve (dashed) and one per variant (colour = planner)."""
    chosen = [c for c in cells if c.row.key == key and c.row.summary == "mean"]
    variants = list(dict.fromkeys(c.variant for c in chosen))
    curves: list[DensityCurve] = []
    for planner in planner_order({c.planner for c in chosen}):
        colour = _PLANNER_COLOURS.get(planner, "")
        name = PLANNER_LABELS.get(planner, planner)
        mine = [c for c in chosen if c.planner == planner]
        published = [(c.density, c.published) for c in mine if c.variant == variants[0]]
        points = [(d, s.mean, s.std) for d, s in published if s is not None]
        if points:
            curves.append(_curve(f"{name}, published", points, colour, "--", published=True))
        for k, variant in enumerate(variants):
            ours = [(c.density, c.ours) for c in mine if c.variant == variant]
            points = [(d, s.mean, float(np.nan_to_num(s.std))) for d, s in ours if s is not None]
            style = _VARIANT_STYLES[k % len(_VARIANT_STYLES)]
            curves.append(_curve(f"{name}, {variant}", points, colour, style))
    return curves


def _curve(
    label: str,
    points: Sequence[tuple[int, float, float]],
    colour: str,
    linestyle: LineStyle,
    published: bool = False,
) -> DensityCurve:
    return DensityCurve(
        label,
        tuple(d for d, _, _ in points),
        tuple(m for _, m, _ in points),
        tuple(s for _, _, s in points),
        published,
        colour,
        linestyle,
    )
