"""The report's adversary section: one row per attack cell (sweep axis ``adversary``, the
family presets of ``configs/adversaries.yaml``) and density, checked against issue 16's bar.

Per cell and planner, means over the completed runs: benign-spoofer NMACs (every spoofer's true
position), the worst spoofer's containment (``containment_rate_min``, else the one spoofer's
``containment_rate``), false alerts, delivered fraction, spoofers caught before their lie could
hurt. The bar (aware): NMACs <= ``MAX_AWARE_NMAC`` per run and at most ``NMAC_RATIO`` of
trust-RID's where trust-RID has >= ``TRUST_NMAC_FLOOR``; containment >= ``MIN_CONTAINMENT``;
no false alert; ghost cells deliver at least ``1 - MAX_GHOST_DELIVERY_LOSS`` of the control cell
``line`` on the same seeds (trust-RID's cost shown beside).
"""

from __future__ import annotations

from collections.abc import Sequence

from ridsafe.tools.analysis.sweep_results import (
    RunRecord,
    SweepResults,
    format_number,
    mean_metric,
)

__all__ = ["AXIS", "adversary_section"]

AXIS = "adversary"
CONTROL = "line"
MAX_AWARE_NMAC = 0.15
NMAC_RATIO = 0.2
TRUST_NMAC_FLOOR = 0.5
MIN_CONTAINMENT = 0.90
MAX_GHOST_DELIVERY_LOSS = 0.02


def _cell(record: RunRecord) -> str | None:
    for name, value in record.params:
        if name == AXIS:
            return str(value)
    return None


def _label(record: RunRecord) -> str:
    return f"`{_cell(record)}` {record.density} {record.planner} seed {record.spec.seed}"


def _containment(records: Sequence[RunRecord]) -> float | None:
    worst = mean_metric(records, "containment_rate_min")
    return worst if worst is not None else mean_metric(records, "containment_rate")


def _deliveries(records: Sequence[RunRecord]) -> dict[int, float]:
    return {
        r.spec.seed: float(r.metrics["goal_reached_fraction"] or 0.0)
        for r in records
        if r.metrics.get("goal_reached_fraction") is not None
    }


def _ghost_cost(cell: Sequence[RunRecord], control: Sequence[RunRecord]) -> float | None:
    """Delivered fraction with ghosts over that of the control cell, same seeds."""
    mine, base = _deliveries(cell), _deliveries(control)
    seeds = sorted(set(mine) & set(base))
    total = sum(base[s] for s in seeds)
    return None if not seeds or total == 0 else sum(mine[s] for s in seeds) / total


def _verdict(
    aware: Sequence[RunRecord], trust: Sequence[RunRecord], ghost_ratio: float | None
) -> str:
    misses = []
    nmac, trust_nmac = (
        mean_metric(aware, "nmac_benign_spoofer"),
        mean_metric(trust, "nmac_benign_spoofer"),
    )
    if nmac is not None and nmac > MAX_AWARE_NMAC:
        misses.append(f"NMAC {nmac:.2f} > {MAX_AWARE_NMAC}")
    floor_met = trust_nmac is not None and trust_nmac >= TRUST_NMAC_FLOOR
    if nmac is not None and trust_nmac is not None and floor_met and nmac > NMAC_RATIO * trust_nmac:
        misses.append(f"NMAC {nmac:.2f} > {NMAC_RATIO} x trust-RID {trust_nmac:.2f}")
    containment = _containment(aware)
    if containment is not None and containment < MIN_CONTAINMENT:
        misses.append(f"containment {containment:.2f} < {MIN_CONTAINMENT}")
    false_alerts = mean_metric(aware, "false_alerts")
    if false_alerts:
        misses.append(f"false alerts {false_alerts:.2f}/run")
    if ghost_ratio is not None and ghost_ratio < 1.0 - MAX_GHOST_DELIVERY_LOSS:
        misses.append(f"deliveries {100 * (1 - ghost_ratio):.1f} % lost to ghosts")
    return "meets" if not misses else "misses: " + "; ".join(misses)


def adversary_section(sweeps: Sequence[SweepResults]) -> list[str]:
    """Markdown lines of the section (none when no sweep has an ``adversary`` axis)."""
    records = [r for s in sweeps for r in s.records if _cell(r) is not None]
    if not records:
        return []
    header = (
        "| Attack | Aircraft | Runs | NMAC b-s aware | NMAC b-s trust-RID | containment (worst "
        "spoofer) | false alerts | delivered aware | delivered trust-RID | vs `line` aware | "
        "vs `line` trust-RID | caught before harm | Verdict |"
    )
    lines = ["", "## Adversaries", "", header, "|" + "---|" * 13]
    cells = list(dict.fromkeys(_cell(r) for r in records))
    for density in sorted({r.density for r in records}):
        for name in cells:

            def pick(planner: str, cell: str | None = name, n: int = density) -> list[RunRecord]:
                return [
                    r
                    for r in records
                    if _cell(r) == cell and r.density == n and r.planner == planner
                ]

            aware, trust = pick("aware"), pick("trust-rid")
            if not aware and not trust:
                continue
            ratio_aware = _ghost_cost(aware, pick("aware", CONTROL))
            ratio_trust = _ghost_cost(trust, pick("trust-rid", CONTROL))
            is_ghost = any(r.metrics.get("ghosts_alerted") is not None for r in aware + trust)
            row = [
                f"`{name}`",
                str(density),
                f"{len(aware)}/{len(trust)}",
                format_number(mean_metric(aware, "nmac_benign_spoofer")),
                format_number(mean_metric(trust, "nmac_benign_spoofer")),
                format_number(_containment(aware)),
                format_number(mean_metric(aware, "false_alerts")),
                format_number(mean_metric(aware, "goal_reached_fraction")),
                format_number(mean_metric(trust, "goal_reached_fraction")),
                format_number(ratio_aware, 3),
                format_number(ratio_trust, 3),
                format_number(mean_metric(aware, "spoofers_alerted_before_harm")),
                _verdict(aware, trust, ratio_aware if is_ghost else None),
            ]
            lines.append("| " + " | ".join(row) + " |")
    on_ground = [r for r in records if (r.metrics.get("spoofer_regions_on_ground") or 0) > 0]
    known = [r for r in records if r.metrics.get("spoofer_regions_on_ground") is not None]
    if known:
        lines += [
            "",
            f"Spoofers taken for a radio on the ground (their region sent flagged ON_GROUND): "
            f"in {len(on_ground)} of {len(known)} runs"
            + (": " + ", ".join(sorted({_label(r) for r in on_ground})) if on_ground else "")
            + ".",
        ]
    lines += _ghost_lines(records, cells)
    lines += [
        "",
        f"Bar (issue 16): aware NMACs <= {MAX_AWARE_NMAC}/run and <= {NMAC_RATIO} x trust-RID's "
        f"where that is >= {TRUST_NMAC_FLOOR}; containment >= {MIN_CONTAINMENT} for every "
        f"spoofer; no false alert; ghosts cost <= {100 * MAX_GHOST_DELIVERY_LOSS:g} % of the "
        f"deliveries of `{CONTROL}` on the same seeds. 'caught before harm': spoofers alerted "
        "before their lie exceeded d_safe - NMAC radius (50 m; a lie from the start counts "
        "as not caught). Containment: the worst spoofer's per run.",
    ]
    return lines


def _paired(
    cell: Sequence[RunRecord], control: Sequence[RunRecord], key: str
) -> list[tuple[float, float]]:
    """(cell's, control's) value of ``key`` on the seeds both have it for."""
    mine = {r.spec.seed: r.metrics.get(key) for r in cell}
    base = {r.spec.seed: r.metrics.get(key) for r in control}
    return [
        (float(a), float(b))
        for seed in sorted(set(mine) & set(base))
        if isinstance(a := mine[seed], int | float) and isinstance(b := base[seed], int | float)
    ]


def _extra_path(cell: Sequence[RunRecord], control: Sequence[RunRecord]) -> float | None:
    """Benign path length flown with ghosts over that of the control, same seeds, minus 1."""
    pairs = _paired(cell, control, "benign_path_length_m")
    total = sum(b for _, b in pairs)
    return None if not pairs or total <= 0.0 else sum(a for a, _ in pairs) / total - 1.0


def _delay(cell: Sequence[RunRecord], control: Sequence[RunRecord]) -> float | None:
    """Mean arrival time with ghosts minus the control's, same seeds (s)."""
    pairs = _paired(cell, control, "mean_arrival_time_s")
    return sum(a - b for a, b in pairs) / len(pairs) if pairs else None


def _percent(value: float | None) -> str:
    return "n/a" if value is None else f"{100.0 * value:+.1f} %"


def _ghost_lines(records: Sequence[RunRecord], cells: Sequence[str | None]) -> list[str]:
    """What the ghosts' regions did (aware planner: the one that reads regions) and what the
    ghosts cost each planner against ``CONTROL`` on the same seeds."""
    rows = []
    for density in sorted({r.density for r in records}):

        def pick(planner: str, cell: str | None, n: int = density) -> list[RunRecord]:
            return [
                r for r in records if _cell(r) == cell and r.density == n and r.planner == planner
            ]

        for name in cells:
            aware, trust = pick("aware", name), pick("trust-rid", name)
            if not any(r.metrics.get("ghosts_alerted") is not None for r in aware + trust):
                continue
            line_aware, line_trust = pick("aware", CONTROL), pick("trust-rid", CONTROL)
            delays = (_delay(aware, line_aware), _delay(trust, line_trust))
            row = [
                f"`{name}`",
                str(density),
                format_number(mean_metric(aware, "ghost_region_containment")),
                format_number(mean_metric(aware, "ghost_on_ground_fraction")),
                format_number(mean_metric(aware, "ghost_on_ground_from_s"), 1),
                format_number(mean_metric(aware, "aircraft_held_by_ghosts")),
                format_number(mean_metric(aware, "pad_hold_s_ghosts"), 1),
                f"{_percent(_extra_path(aware, line_aware))} / "
                f"{_percent(_extra_path(trust, line_trust))}",
                " / ".join("n/a" if d is None else f"{d:+.1f}" for d in delays),
            ]
            rows.append("| " + " | ".join(row) + " |")
    if not rows:
        return []
    return [
        "",
        "Ghosts (means per run; the region columns for the aware planner, which reads "
        "regions): how often the ghosts' regions contain their radio and were sent flagged "
        "ON_GROUND (a radio on the ground, `gcs/region/ground.py`), from when, the take-offs "
        "and landings their regions held (`companion/pad_clearance.py`), and what the ghosts "
        f"cost against `{CONTROL}` on the same seeds: benign path length and mean arrival time "
        "(aware / trust-RID).",
        "",
        "| Attack | Aircraft | ghost regions holding the radio | on the ground | first on the "
        "ground (s) | aircraft held by a ghost | held by ghosts (aircraft-s) | path vs "
        f"`{CONTROL}` | arrival vs `{CONTROL}` (s) |",
        "|" + "---|" * 9,
        *rows,
    ]
