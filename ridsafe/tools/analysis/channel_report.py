"""The report's channel section: every radio setting of a robustness sweep against issue 15's
bar, and by how much a setting misses it.

A sweep is a channel sweep when its config's GCS always fits the channel
(``pipeline.calibration.enabled: true``, e.g. ``configs/robustness.yaml``,
``configs/urban.yaml``) or one of its axes sets a ``scenario.radio`` key. One row per
(variant, density): the GCS's numbers from the aware runs (containment, RMSE, detection
delay median / 90th percentile / worst over runs, false alerts), benign-spoofer NMACs of
both planners, the aware planner's delivered fraction.

The bar: no false alert (an alert on a bystander, an honest aircraft outside the fleet, is
one; the verdict says in how many runs one was); containment >= ``MIN_CONTAINMENT`` and
RMSE <= ``MAX_RMSE_M`` (the 16-aircraft values from 16 aircraft up, the 8-aircraft ones
below); detection delay median <= ``MAX_DELAY_MEDIAN_S`` and 90th percentile <=
``MAX_DELAY_P90_S``; aware benign-spoofer NMACs <= ``MAX_AWARE_NMAC`` per run and at most
``NMAC_RATIO`` of trust-RID's; goal reached >= ``MIN_GOAL``. A run without an alert has no
delay: its row counts such runs.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ridsafe.tools.analysis.sweep_results import (
    RunRecord,
    SweepResults,
    format_number,
    mean_metric,
)

__all__ = ["channel_section", "is_channel_sweep"]

#: aircraft -> bar; a density uses the entry of the largest key not above it (8 below 8).
MIN_CONTAINMENT = {8: 0.85, 16: 0.90}
MAX_RMSE_M = {8: 60.0, 16: 40.0}
MAX_DELAY_MEDIAN_S = 5.0
MAX_DELAY_P90_S = 15.0
MAX_AWARE_NMAC = 0.15
NMAC_RATIO = 0.2
MIN_GOAL = 0.95


def is_channel_sweep(sweep: SweepResults) -> bool:
    """Its GCS calibrates, or an axis sets a radio key."""
    return sweep.calibrating or any(
        key.startswith("scenario.radio.") for r in sweep.records for key, _ in r.spec.overrides
    )


def _for_density(bar: dict[int, float], density: int) -> float:
    keys = [k for k in sorted(bar) if k <= density]
    return bar[keys[-1] if keys else min(bar)]


def _delays(records: Sequence[RunRecord]) -> tuple[list[float], int]:
    """(detection delays of the runs that alerted, runs without one)."""
    delays = [r.metrics.get("detection_delay_s") for r in records]
    known = [float(d) for d in delays if isinstance(d, int | float)]
    return known, len(delays) - len(known)


def _on_bystanders(records: Sequence[RunRecord]) -> str:
    """The verdict's word on bystanders where the runs flew them (in how many runs one was
    alerted); empty where they did not."""
    flew = [r for r in records if r.metrics.get("bystander_count")]
    if not flew:
        return ""
    alerted = sum(1 for r in flew if r.metrics.get("bystanders_alerted"))
    return f" (a bystander alerted in {alerted} of {len(flew)} runs)"


def _verdict(aware: Sequence[RunRecord], trust: Sequence[RunRecord], density: int) -> str:
    misses: list[str] = []
    false_alerts = mean_metric(aware, "false_alerts")
    if false_alerts:
        misses.append(f"false alerts {false_alerts:.2f}/run{_on_bystanders(aware)}")
    containment = mean_metric(aware, "containment_rate")
    floor = _for_density(MIN_CONTAINMENT, density)
    if containment is not None and containment < floor:
        misses.append(f"containment {floor - containment:.3f} short of {floor}")
    rmse = mean_metric(aware, "rmse_m")
    ceiling = _for_density(MAX_RMSE_M, density)
    if rmse is not None and rmse > ceiling:
        misses.append(f"RMSE {rmse - ceiling:.0f} m over {ceiling:g}")
    delays, missed = _delays(aware)
    if missed:
        misses.append(f"{missed} run(s) never alerted")
    if delays:
        median, p90 = float(np.median(delays)), float(np.quantile(delays, 0.9))
        if median > MAX_DELAY_MEDIAN_S:
            misses.append(f"delay median {median - MAX_DELAY_MEDIAN_S:.1f} s over")
        if p90 > MAX_DELAY_P90_S:
            misses.append(f"delay p90 {p90 - MAX_DELAY_P90_S:.1f} s over")
    nmac, trust_nmac = (mean_metric(rs, "nmac_benign_spoofer") for rs in (aware, trust))
    if nmac is not None and nmac > MAX_AWARE_NMAC:
        misses.append(f"NMAC {nmac:.2f} > {MAX_AWARE_NMAC}")
    if nmac is not None and trust_nmac is not None and nmac > NMAC_RATIO * trust_nmac:
        misses.append(f"NMAC {nmac:.2f} > {NMAC_RATIO} x trust-RID {trust_nmac:.2f}")
    goal = mean_metric(aware, "goal_reached_fraction")
    if goal is not None and goal < MIN_GOAL:
        misses.append(f"goal {MIN_GOAL - goal:.3f} short of {MIN_GOAL}")
    return "meets" if not misses else "misses: " + "; ".join(misses)


def _row(label: str, density: int, aware: list[RunRecord], trust: list[RunRecord]) -> list[str]:
    delays, missed = _delays(aware)
    if delays:
        spread = np.quantile(delays, (0.5, 0.9, 1.0))
        delay = " / ".join(f"{d:.1f}" for d in spread) + (f" ({missed} none)" if missed else "")
    else:
        delay = "n/a"
    return [
        label,
        str(density),
        f"{len(aware)}/{len(trust)}",
        format_number(mean_metric(aware, "containment_rate"), 3),
        format_number(mean_metric(aware, "rmse_m"), 1),
        delay,
        format_number(mean_metric(aware, "false_alerts")),
        format_number(mean_metric(aware, "nmac_benign_spoofer")),
        format_number(mean_metric(trust, "nmac_benign_spoofer")),
        format_number(mean_metric(aware, "goal_reached_fraction"), 3),
        _verdict(aware, trust, density),
    ]


def channel_section(sweeps: Sequence[SweepResults]) -> list[str]:
    """Markdown lines of the section (none when no sweep is a channel sweep)."""
    rows: list[list[str]] = []
    for sweep in sweeps:
        if not is_channel_sweep(sweep):
            continue
        for params, label in sweep.variants():
            runs = [r for r in sweep.records if r.params == params]
            for density in sorted({r.density for r in runs}):
                aware = [r for r in runs if r.density == density and r.planner == "aware"]
                trust = [r for r in runs if r.density == density and r.planner == "trust-rid"]
                rows.append(_row(label, density, aware, trust))
    if not rows:
        return []
    header = (
        "Setting",
        "Aircraft",
        "Runs aware/trust-RID",
        "containment",
        "RMSE (m)",
        "delay median / p90 / worst (s)",
        "false alerts",
        "NMAC b-s aware",
        "NMAC b-s trust-RID",
        "goal aware",
        "Verdict",
    )
    lines = ["", "## Channel robustness", ""]
    lines += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    c8, c16 = MIN_CONTAINMENT[8], MIN_CONTAINMENT[16]
    r8, r16 = MAX_RMSE_M[8], MAX_RMSE_M[16]
    lines += [
        "",
        f"Bar (issue 15; the GCS's numbers from the aware runs): no false alert; containment >= "
        f"{c16} and RMSE <= {r16:g} m from 16 aircraft up ({c8} and {r8:g} m below); detection "
        f"delay after four aircraft heard the spoofer median <= {MAX_DELAY_MEDIAN_S:g} s and "
        f"90th percentile <= {MAX_DELAY_P90_S:g} s; aware benign-spoofer NMACs <= "
        f"{MAX_AWARE_NMAC}/run and <= {NMAC_RATIO} x trust-RID's; goal reached >= {MIN_GOAL}.",
    ]
    return lines
