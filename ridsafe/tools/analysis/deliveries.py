"""Why an aircraft did or did not deliver: one row per benign aircraft, from the log alone.

``goal_reached_fraction`` says how many delivered; this says what became of the others, so a
drop in deliveries can be traced to its kind before anything is tuned. Per aircraft of
``/run/meta`` (true positions, ``/truth/vehicles``):

- ``took_off_s``: its first airborne sample (armed, above the metrics' airborne height);
  ``arrived_s``: its first sample within the arrival radius of its goal, horizontally (the
  ``goal_reached_fraction`` definition); ``trip_m``: its start to its goal, horizontally;
- ``flight_s`` and ``progress_m_s``: take-off to arrival (or to the end of the run) and the
  trip covered per second of it (for an aircraft that did not arrive: the trip less what was
  left at the end);
- ``low_fraction``: the part of that flight spent more than :data:`LOW_MARGIN_M` below its
  cruise altitude (the climb from the pad included);
- ``landed_s``: for an aircraft that arrived, its first sample on the ground (or disarmed)
  on its site (within the arrival radius) after that: the delivery done and the airspace
  above the site free again (None: still in the air at the end, or down beside its site);
- ``descending_at_end``: for an aircraft that arrived and was still in the air at the end
  (None for the others), whether it was on its way down: within the arrival radius of its
  goal and losing at least :data:`DESCENDING_MIN_M_S` of height a second over the last
  :data:`DESCENT_WINDOW_S` (a descent from cruise height at an autopilot's usual 1.5 m/s,
  0.5 m/s for the last 10 m, takes 40-60 s); False: off its site or holding its height,
  what traffic at the site can cause;
- ``down_beside_site``: for an aircraft that arrived, whether it ended on the ground off its
  site (beyond the arrival radius): a package delivered to the wrong place;
- ``end_from_goal_m``, ``closest_m``: horizontal distance to its goal at the end, and the least;
  ``near_goal_s``: when it first came within :data:`NEAR_GOAL_M` of its goal (None: never);
- ``holder_sysid`` / ``holder_stage``: for an aircraft held near its goal, the other aircraft
  that was most often the closest airborne one to its goal while it was held there, and the
  stage of that aircraft's flight then (its mission phase; ``flight_histories.Stage``);
- ``outcome`` (:class:`Outcome`): ``delivered``; ``not launched``; ``held near the goal``
  (it came within :data:`NEAR_GOAL_M` of it at least :data:`HELD_S` before the end, and
  never within the arrival radius); ``late`` (still closing on its goal at
  :data:`CLOSING_MIN_M_S` or more over the last :data:`CLOSING_WINDOW_S`); ``stalled en
  route`` (neither).

``ridsafe metrics RUN.mcap --deliveries`` lists them.
"""

from __future__ import annotations

import collections
import dataclasses
import enum
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ridsafe.tools.analysis.encounters import airborne
from ridsafe.tools.analysis.flight_histories import Stage, flight_histories, stage_of, value_at
from ridsafe.tools.analysis.metrics import (
    DEFAULT_MIN_HEIGHT_M,
    arrival_times_s,
    landing_times_s,
)
from ridsafe.tools.analysis.run_arrays import RunLog

__all__ = [
    "CLOSING_MIN_M_S",
    "CLOSING_WINDOW_S",
    "DESCENDING_MIN_M_S",
    "DESCENT_WINDOW_S",
    "HELD_S",
    "LOW_MARGIN_M",
    "NEAR_GOAL_M",
    "Delivery",
    "Outcome",
    "deliveries",
    "outcome_counts",
]

FloatArray = NDArray[np.float64]

#: Within this of its goal (horizontally, m) an aircraft is "near" it: the NMAC radius, so an
#: aircraft hovering or landing at the goal holds back one that comes this close.
NEAR_GOAL_M = 50.0
#: Near its goal this long before the end (s) without arriving: held there, not merely late.
HELD_S = 20.0
#: Closing on its goal at least this fast (m/s) over the last ``CLOSING_WINDOW_S``: late.
CLOSING_MIN_M_S = 2.0
CLOSING_WINDOW_S = 20.0
#: More than this below its cruise altitude (m) counts as flying low.
LOW_MARGIN_M = 15.0
#: An arrived aircraft losing height at least this fast (m/s) over the last
#: ``DESCENT_WINDOW_S`` is still descending (ArduCopter's final LAND_SPEED is 0.5 m/s).
DESCENDING_MIN_M_S = 0.3
DESCENT_WINDOW_S = 5.0


class Outcome(enum.Enum):
    """What became of one aircraft's delivery (definitions: the module docstring)."""

    DELIVERED = "delivered"
    NOT_LAUNCHED = "not launched"
    HELD_NEAR_GOAL = "held near the goal"
    LATE = "late"
    STALLED = "stalled en route"


@dataclass(frozen=True)
class Delivery:
    """One benign aircraft's delivery (fields: the module docstring)."""

    sysid: int
    outcome: Outcome
    trip_m: float
    took_off_s: float | None = None
    arrived_s: float | None = None
    landed_s: float | None = None
    descending_at_end: bool | None = None
    down_beside_site: bool = False
    flight_s: float | None = None
    progress_m_s: float | None = None
    low_fraction: float | None = None
    end_from_goal_m: float | None = None
    closest_m: float | None = None
    near_goal_s: float | None = None
    holder_sysid: int | None = None
    holder_stage: Stage | None = None


def _closing_m_s(t_s: FloatArray, from_goal_m: FloatArray) -> float:
    """How fast the distance to the goal shrank over the last ``CLOSING_WINDOW_S``."""
    start = int(np.searchsorted(t_s, t_s[-1] - CLOSING_WINDOW_S))
    span_s = float(t_s[-1] - t_s[start])
    return float(from_goal_m[start] - from_goal_m[-1]) / span_s if span_s > 0.0 else 0.0


def _holder(
    run: RunLog, sysid: int, goal: FloatArray, since: int, flying: NDArray[np.bool_]
) -> int | None:
    """The other aircraft most often the closest airborne one to ``goal`` (within
    ``NEAR_GOAL_M``) from sample ``since`` on."""
    truth = run.truth
    others = [s for s in run.benign_sysids if s != sysid and truth.column(s) is not None]
    if not others:
        return None
    columns = np.array([truth.column(s) for s in others])
    p = truth.p_enu_m[since:, columns, :2]
    with np.errstate(invalid="ignore"):
        d = np.hypot(p[..., 0] - goal[0], p[..., 1] - goal[1])
    d = np.where(flying[since:, columns] & (d <= NEAR_GOAL_M), d, np.inf)
    held = np.isfinite(d).any(axis=1)
    if not held.any():
        return None
    nearest = np.argmin(d[held], axis=1)
    return int(others[collections.Counter(nearest.tolist()).most_common(1)[0][0]])


def deliveries(run: RunLog, min_height_m: float = DEFAULT_MIN_HEIGHT_M) -> list[Delivery]:
    """Every benign aircraft's :class:`Delivery`, by sysid (those without a goal left out)."""
    if run.truth.t_s.size == 0:
        return []
    flying = airborne(run.truth.p_enu_m, run.truth.armed, min_height_m)
    arrivals = arrival_times_s(run)
    landings = landing_times_s(run, arrivals, flying)
    meta = {int(a["sysid"]): a for a in run.meta.get("aircraft") or [] if "sysid" in a}
    rows = [
        _delivery(run, sysid, meta.get(sysid, {}), arrivals.get(sysid), landings.get(sysid), flying)
        for sysid in sorted(run.goals_enu_m)
    ]
    held_at = {  # sysid -> the sample from which it was near its goal
        row.sysid: int(np.searchsorted(run.truth.t_s, row.near_goal_s))
        for row in rows
        if row.outcome is Outcome.HELD_NEAR_GOAL and row.near_goal_s is not None
    }
    return _with_holders(run, rows, held_at, flying)


def _delivery(
    run: RunLog,
    sysid: int,
    meta: Mapping[str, Any],
    arrived: float | None,
    landed: float | None,
    flying: NDArray[np.bool_],
) -> Delivery:
    """One aircraft's row, without who held it."""
    truth = run.truth
    goal = np.asarray(run.goals_enu_m[sysid], dtype=np.float64)
    column = truth.column(sysid)
    start = meta.get("start_enu_m")
    up = np.flatnonzero(flying[:, column]) if column is not None else np.array([], int)
    if column is None or up.size == 0:
        trip = float(np.hypot(*(np.asarray(start[:2]) - goal[:2]))) if start else np.nan
        return Delivery(sysid, Outcome.NOT_LAUNCHED, trip)
    p = truth.p_enu_m[:, column]
    first = int(up[0])
    origin = np.asarray(start[:2], dtype=np.float64) if start else p[first, :2]
    trip = float(np.hypot(*(origin - goal[:2])))
    with np.errstate(invalid="ignore"):
        from_goal = np.hypot(p[:, 0] - goal[0], p[:, 1] - goal[1])
    last = int(np.searchsorted(truth.t_s, arrived)) if arrived is not None else len(truth.t_s)
    took_off = float(truth.t_s[first])
    flight = float(truth.t_s[min(last, len(truth.t_s) - 1)]) - took_off
    cruise, heights = meta.get("cruise_alt_m"), p[first:last, 2]
    low = None
    if cruise is not None and heights.size:
        low = float(np.mean(heights < float(cruise) - LOW_MARGIN_M))
    covered = trip - (0.0 if arrived is not None else float(from_goal[-1]))
    near = np.flatnonzero(from_goal <= NEAR_GOAL_M)
    near_s = float(truth.t_s[near[0]]) if near.size else None
    descending, beside = None, False
    if arrived is not None and landed is None:
        if flying[-1, column]:
            end_from_goal = float(from_goal[-1])
            descending = _descending(truth.t_s, p[:, 2], end_from_goal, run.arrival_radius_m)
        else:
            beside = True
    return Delivery(
        sysid=sysid,
        outcome=_outcome(truth.t_s, from_goal, arrived, near_s),
        trip_m=trip,
        took_off_s=took_off,
        arrived_s=arrived,
        landed_s=landed,
        descending_at_end=descending,
        down_beside_site=beside,
        flight_s=flight,
        progress_m_s=covered / flight if flight > 0.0 else None,
        low_fraction=low,
        end_from_goal_m=float(from_goal[-1]),
        closest_m=float(np.nanmin(from_goal)),
        near_goal_s=near_s,
    )


def _descending(
    t_s: FloatArray, up_m: FloatArray, end_from_goal_m: float, arrival_radius_m: float
) -> bool:
    """Whether an arrived aircraft still in the air is on its way down over its site."""
    start = int(np.searchsorted(t_s, t_s[-1] - DESCENT_WINDOW_S))
    span_s = float(t_s[-1] - t_s[start])
    sink_m_s = float(up_m[start] - up_m[-1]) / span_s if span_s > 0.0 else 0.0
    return end_from_goal_m <= arrival_radius_m and sink_m_s >= DESCENDING_MIN_M_S


def _outcome(
    t_s: FloatArray, from_goal_m: FloatArray, arrived_s: float | None, near_s: float | None
) -> Outcome:
    """The outcome of a launched aircraft (definitions: the module docstring)."""
    if arrived_s is not None:
        return Outcome.DELIVERED
    if near_s is not None and t_s[-1] - near_s >= HELD_S:
        return Outcome.HELD_NEAR_GOAL
    if _closing_m_s(t_s, from_goal_m) >= CLOSING_MIN_M_S:
        return Outcome.LATE
    return Outcome.STALLED


def _with_holders(
    run: RunLog, rows: list[Delivery], held_at: dict[int, int], flying: NDArray[np.bool_]
) -> list[Delivery]:
    """The rows, those held near their goal with who held them and in which stage."""
    if not held_at:
        return rows
    holders = {
        sysid: _holder(run, sysid, np.asarray(run.goals_enu_m[sysid]), since, flying)
        for sysid, since in held_at.items()
    }
    phases, _ = flight_histories(run, {h for h in holders.values() if h is not None})
    out = []
    for row in rows:
        holder = holders.get(row.sysid)
        if holder is not None and row.near_goal_s is not None:
            # its stage half-way through the hold
            t_mid = 0.5 * (row.near_goal_s + float(run.truth.t_s[-1]))
            stage = stage_of(value_at(phases.get(holder, []), t_mid))
            out.append(dataclasses.replace(row, holder_sysid=holder, holder_stage=stage))
        else:
            out.append(row)
    return out


def outcome_counts(rows: Sequence[Delivery]) -> dict[Outcome, int]:
    """How many aircraft had each outcome (every :class:`Outcome`, zeros included)."""
    counts = collections.Counter(row.outcome for row in rows)
    return {outcome: counts.get(outcome, 0) for outcome in Outcome}
