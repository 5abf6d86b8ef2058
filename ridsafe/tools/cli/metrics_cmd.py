"""``ridsafe metrics``: a run's metrics from its log, as a table or as JSON.

``ridsafe metrics OUT/run.mcap`` prints one line per metric (``n/a`` where it does not
apply); ``--json`` prints the dict of ``ridsafe.tools.analysis.metrics.compute_metrics`` (``null``
where it does not apply). ``--nmacs`` adds every benign-spoofer NMAC, one line each (in JSON:
``spoofer_nmac_events``, a list of objects): when, how close, at what height, in which stage of
the benign aircraft's flight, how long after the spoofer's alert, and whether the spoofer was
inside its unsafe region (``ridsafe.tools.analysis.spoofer_nmacs``). ``--deliveries`` adds what
became of every aircraft that did not deliver, one line each (in JSON: ``deliveries``, every
aircraft): late, held near its goal (and by which aircraft, in which stage of its flight),
stalled en route or not launched, with its trip, progress and time flown low
(``ridsafe.tools.analysis.deliveries``). A file that cannot be read
as a run log: message on stderr, exit 1. Definitions: the docstring of
``ridsafe.tools.analysis.metrics``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import sys
from collections.abc import Mapping, Sequence
from typing import Any

from ridsafe.common.errors import RidsafeError
from ridsafe.tools.analysis.deliveries import (
    NEAR_GOAL_M,
    Delivery,
    Outcome,
    deliveries,
    outcome_counts,
)
from ridsafe.tools.analysis.metrics import METRIC_KEYS, compute_metrics
from ridsafe.tools.analysis.run_arrays import load_run
from ridsafe.tools.analysis.spoofer_nmacs import SpooferNmac, spoofer_nmacs

NEAR_GOAL_TEXT = f"{NEAR_GOAL_M:.0f} m"

# metric -> (label, unit, format)
_DISPLAY: dict[str, tuple[str, str, str]] = {
    "nmac_benign_benign": ("NMAC benign-benign", "events", "d"),
    "nmac_benign_spoofer": ("NMAC benign-spoofer", "events", "d"),
    "unsafe_violations": ("unsafe-region entries", "events", "d"),
    "containment_rate": ("containment rate (LCR)", "", ".3f"),
    "rmse_m": ("spoofer RMSE", "m", ".1f"),
    "mae_m": ("spoofer MAE", "m", ".1f"),
    "max_ellipsoid_radius_m": ("max ellipsoid radius", "m", ".1f"),
    "min_distance_to_spoofer_m": ("min distance to spoofer", "m", ".1f"),
    "goal_reached_fraction": ("goal reached", "fraction", ".3f"),
    "landed_fraction": ("landed on its site", "fraction", ".3f"),
    "alert_time_s": ("first alert", "s", ".2f"),
    "detection_delay_s": ("alert after 4 aircraft heard it", "s", ".2f"),
    "region_delay_s": ("first region after the alert", "s", ".2f"),
    "false_alerts": ("false alerts", "alerts", "d"),
    "false_alerts_per_aircraft_hour": ("false alerts per aircraft-hour", "/ac-h", ".2f"),
    "wall_clock_s": ("wall clock", "s", ".1f"),
    "gcs_compute_s": ("GCS compute", "s", ".2f"),
    "gcs_update_p99_ms": ("GCS update p99", "ms", ".2f"),
    "planner_decision_p99_ms": ("planner decision p99", "ms", ".2f"),
    "autopilot_failsafes": ("autopilot failsafes", "events", "d"),
    # The paper's own definitions (analysis/paper_metrics.py): 0.25 s ticks, arrived excluded.
    "paper_nmac_benign_benign": ("paper: NMAC benign-benign", "events", "d"),
    "paper_nmac_benign_spoofer": ("paper: NMAC benign-spoofer", "events", "d"),
    "paper_unsafe_violations": ("paper: unsafe violations", "events", "d"),
    "paper_containment_rate": ("paper: containment", "", ".3f"),
    "paper_rmse_m": ("paper: region-centre RMSE", "m", ".1f"),
    "paper_mae_m": ("paper: region-centre MAE", "m", ".1f"),
    "paper_mean_ellipsoid_radius_m": ("paper: mean ellipsoid radius", "m", ".1f"),
    "paper_mean_horizontal_radius_m": ("paper: ... its horizontal", "m", ".1f"),
}


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "metrics",
        help="compute a run's metrics from its MCAP log",
        description="Compute NMACs, containment, localisation error and cost from a run log "
        "(DESIGN.md section 7).",
    )
    parser.add_argument("log", help="the run log, e.g. OUT/run.mcap")
    parser.add_argument("--json", action="store_true", help="print the metrics as JSON")
    parser.add_argument(
        "--nmacs", action="store_true", help="also list every benign-spoofer NMAC, one a line"
    )
    parser.add_argument(
        "--deliveries",
        action="store_true",
        help="also list what became of every aircraft that did not deliver, one a line",
    )
    parser.set_defaults(func=run)


def format_table(metrics: Mapping[str, float | int | None]) -> str:
    """One aligned line per metric, in :data:`METRIC_KEYS` order."""
    lines = []
    for key in METRIC_KEYS:
        label, unit, fmt = _DISPLAY[key]
        value = metrics.get(key)
        text = "n/a" if value is None else format(value, fmt)
        lines.append(f"{label:<26} {text:>10}  {unit}".rstrip())
    return "\n".join(lines)


def format_nmacs(events: Sequence[SpooferNmac]) -> str:
    """One line per benign-spoofer NMAC event (``--nmacs``)."""
    lines = [f"benign-spoofer NMACs: {len(events)}"]
    for e in events:
        since = "never alerted" if e.alert_lag_s is None else f"{e.alert_lag_s:+.1f} s from alert"
        region = {None: "no region", True: "inside its region", False: "outside its region"}
        lines.append(
            f"  t {e.t_s:6.1f} s  aircraft {e.benign_sysid} - {e.spoofer_serial}  "
            f"{e.distance_m:.1f} m  height {e.height_m:.1f} m  {e.stage.value} "
            f"({e.phase or 'no phase'})  {since}  spoofer {region[e.in_region]}  "
            f"planner {e.planner_status or 'none'}"
        )
    return "\n".join(lines)


def _optional(value: float | None, fmt: str, unit: str = "") -> str:
    return "n/a" if value is None else f"{value:{fmt}}{unit}"


def format_deliveries(rows: Sequence[Delivery]) -> str:
    """A count per outcome, then one line per aircraft that did not deliver (``--deliveries``)."""
    counts = outcome_counts(rows)
    summary = ", ".join(f"{n} {outcome.value}" for outcome, n in counts.items() if n)
    lines = [f"deliveries of {len(rows)} aircraft: {summary or 'none'}"]
    arrived = [row for row in rows if row.arrived_s is not None]
    landing_s = [
        r.landed_s - r.arrived_s
        for r in arrived
        if r.landed_s is not None and r.arrived_s is not None
    ]
    if arrived:
        median = (
            f", median {statistics.median(landing_s):.1f} s after arriving" if landing_s else ""
        )
        beside = [r.sysid for r in arrived if r.down_beside_site]
        off_site = (
            f"; {len(beside)} down beside their sites (aircraft {', '.join(map(str, beside))})"
            if beside
            else ""
        )
        lines.append(
            f"  landed within the run: {len(landing_s)} of the {len(arrived)} that arrived"
            f"{median}{off_site}"
        )
        descending = sum(r.descending_at_end is True for r in arrived)
        not_descending = [r.sysid for r in arrived if r.descending_at_end is False]
        if descending or not_descending:
            which = f" (aircraft {', '.join(map(str, not_descending))})" if not_descending else ""
            lines.append(
                f"  in the air at the end: {descending} descending over their sites, "
                f"{len(not_descending)} not descending{which}"
            )
    for row in rows:
        if row.outcome is Outcome.DELIVERED:
            continue
        held = ""
        if row.holder_sysid is not None:
            stage = row.holder_stage.value if row.holder_stage is not None else "unknown"
            held = f"  nearest at its goal: aircraft {row.holder_sysid} ({stage})"
        lines.append(
            f"  aircraft {row.sysid}: {row.outcome.value}  trip {row.trip_m:.0f} m  "
            f"took off {_optional(row.took_off_s, '.1f', ' s')}  "
            f"progress {_optional(row.progress_m_s, '.1f', ' m/s')}  "
            f"low {_optional(row.low_fraction, '.0%')}  "
            f"{_optional(row.end_from_goal_m, '.0f', ' m')} from its goal at the end "
            f"(closest {_optional(row.closest_m, '.0f', ' m')}, within "
            f"{NEAR_GOAL_TEXT} from {_optional(row.near_goal_s, '.1f', ' s')}){held}"
        )
    return "\n".join(lines)


def _as_json(event: SpooferNmac) -> dict[str, Any]:
    return {**dataclasses.asdict(event), "stage": event.stage.value}


def _delivery_json(row: Delivery) -> dict[str, Any]:
    stage = None if row.holder_stage is None else row.holder_stage.value
    return {**dataclasses.asdict(row), "outcome": row.outcome.value, "holder_stage": stage}


def run(args: argparse.Namespace) -> int:
    try:
        run_log = load_run(args.log)
        metrics = compute_metrics(run_log)
        events = spoofer_nmacs(run_log) if args.nmacs else []
        rows = deliveries(run_log) if args.deliveries else []
    except (RidsafeError, OSError) as exc:
        print(f"ridsafe metrics: {exc}", file=sys.stderr)
        return 1
    except (KeyError, TypeError, ValueError) as exc:
        print(f"ridsafe metrics: {args.log}: malformed run log: {exc!r}", file=sys.stderr)
        return 1
    if args.json:
        extra: dict[str, Any] = {}
        if args.nmacs:
            extra["spoofer_nmac_events"] = [_as_json(e) for e in events]
        if args.deliveries:
            extra["deliveries"] = [_delivery_json(row) for row in rows]
        print(json.dumps({**metrics, **extra}, indent=2))
    else:
        parts = [format_table(metrics)]
        if args.nmacs:
            parts.append(format_nmacs(events))
        if args.deliveries:
            parts.append(format_deliveries(rows))
        print("\n".join(parts))
    return 0
