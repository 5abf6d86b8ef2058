"""The report's section on where the aware planner's benign-spoofer NMACs happen.

For every sweep variant (and density) with an aware run that had one: a summary row (how many
NMACs in how many runs, by flight stage, how many before the spoofer's alert, and whether the
spoofer was inside, outside or without an unsafe region then), then one row per NMAC
(``analysis.spoofer_nmacs``). Only the logs of the aware runs with an NMAC are read; a run
whose log cannot be read is named, never left out silently.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from ridsafe.tools.analysis.flight_histories import Stage
from ridsafe.tools.analysis.run_arrays import load_run
from ridsafe.tools.analysis.spoofer_nmacs import SpooferNmac, spoofer_nmacs
from ridsafe.tools.analysis.sweep_results import RunRecord, SweepResults, format_number
from ridsafe.tools.runlog.reader import LogReadError
from ridsafe.tools.sweep.folder import LOG_FILE

__all__ = ["nmac_section"]

PLANNER = "aware"
_REGION = {True: "inside", False: "outside", None: "no region"}


@dataclass(frozen=True)
class _Group:
    """The aware runs of one variant and density, and the NMACs read from their logs."""

    label: str
    density: int
    runs: int
    events: tuple[tuple[RunRecord, SpooferNmac], ...]
    runs_with: int
    unread: tuple[str, ...]


def _read(label: str, density: int, records: Sequence[RunRecord]) -> _Group:
    events: list[tuple[RunRecord, SpooferNmac]] = []
    unread: list[str] = []
    with_nmacs = [r for r in records if (r.metrics.get("nmac_benign_spoofer") or 0) > 0]
    for record in sorted(with_nmacs, key=lambda r: r.spec.seed):
        try:
            events += [(record, e) for e in spoofer_nmacs(load_run(record.run_dir / LOG_FILE))]
        except (OSError, LogReadError) as error:
            unread.append(f"{label} {density} seed {record.spec.seed} ({error})")
    return _Group(label, density, len(records), tuple(events), len(with_nmacs), tuple(unread))


def _groups(sweeps: Sequence[SweepResults]) -> list[_Group]:
    groups = []
    for sweep in sweeps:
        for params, label in sweep.variants():
            mine = [r for r in sweep.records if r.params == params and r.planner == PLANNER]
            for density in sorted({r.density for r in mine}):
                records = [r for r in mine if r.density == density]
                groups.append(_read(label, density, records))
    return [g for g in groups if g.runs_with]


def _summary_row(g: _Group) -> str:
    events = [e for _r, e in g.events]
    stages = [sum(1 for e in events if e.stage is stage) for stage in Stage]
    before = sum(1 for e in events if e.alert_lag_s is None or e.alert_lag_s < 0.0)
    region = [sum(1 for e in events if e.in_region is key) for key in _REGION]
    row = [
        g.label,
        str(g.density),
        f"{g.runs_with} / {g.runs}",
        str(len(events)),
        *map(str, stages),
    ]
    return "| " + " | ".join([*row, str(before), " / ".join(map(str, region))]) + " |"


def _event_row(g: _Group, record: RunRecord, e: SpooferNmac) -> str:
    since = "never" if e.alert_lag_s is None else f"{e.alert_lag_s:+.1f}"
    row = [
        g.label,
        str(g.density),
        str(record.spec.seed),
        f"{e.t_s:.1f}",
        f"{e.distance_m:.1f}",
        f"{e.height_m:.1f}",
        f"{e.stage.value} ({e.phase or 'no phase'})",
        f"{format_number(e.from_pad_m, 0)} / {format_number(e.from_goal_m, 0)}",
        since,
        _REGION[e.in_region],
        e.planner_status or "none",
    ]
    return "| " + " | ".join(row) + " |"


def nmac_section(sweeps: Sequence[SweepResults]) -> list[str]:
    """Markdown lines of the section (none when no aware run had a benign-spoofer NMAC)."""
    groups = _groups(sweeps)
    if not groups:
        return []
    stage_names = " | ".join(stage.value for stage in Stage)
    lines = [
        "",
        "## Where the aware planner's benign-spoofer NMACs happen",
        "",
        "Each NMAC at its closest sample (`analysis/spoofer_nmacs.py`): the benign aircraft's "
        "flight stage (its mission phase), whether the spoofer had been alerted, whether "
        "its true position was inside the last unsafe region the GCS had sent for it (no "
        "region: none in the second before), and the benign planner's status then "
        "(`no_safe_action`: no action kept clear of every region).",
        "",
        f"| Variant | Aircraft | runs with one | NMACs | {stage_names} | before the alert | "
        "spoofer inside / outside / no region |",
        "|" + "---|" * (6 + len(Stage)),
        *(_summary_row(g) for g in groups),
        "",
        "| Variant | Aircraft | seed | t (s) | distance (m) | height (m) | stage (phase) | from "
        "pad / goal (m) | since alert (s) | spoofer vs its region | planner |",
        "|" + "---|" * 11,
        *(_event_row(g, record, e) for g in groups for record, e in g.events),
    ]
    unread = [u for g in groups for u in g.unread]
    if unread:
        lines += ["", "Logs not read: " + "; ".join(unread) + "."]
    return lines
