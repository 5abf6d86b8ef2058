"""Observation reports -> observed claims: validation, grouping, bounded history. Pure (no I/O).

Each companion reports every RID location broadcast it heard (``messages.Observation``,
geodetic; a companion's batch as ``messages.ObservationRows``). The GCS turns one report into
one reception (receive time, receiver position in the scenario ENU frame about the origin,
``frames.geodetic_to_enu``, RSSI, receiver id) and groups the receptions of one broadcast by
its key ``(uas_id, rid_timestamp_s)``. A group opens at its first reception (GCS sim time
``t0``) and closes once ``now_s - t0 >= group_window_s``, so receptions of one broadcast that
arrive over a few ticks end up together; closed groups become
``pipeline_api.ObservedClaim`` objects, receptions sorted by receiver id.

A report is rejected, counted by :class:`RejectReason` and never raised, when:

- its id is empty; any value is NaN/inf; a latitude/longitude is out of range; its RSSI or an
  altitude is outside the configured plausible range; a position is farther than
  ``max_distance_m`` from the origin;
- its receive time ``t`` is in the future (``t > now + future_tolerance_s``) or older than the
  history window (``t < now - history_window_s``);
- the same receiver already reported this transmission (duplicate), the transmission already
  closed (late), or too many transmissions are open.

Claimed velocity (ENU) from the broadcast's course ``c`` (clockwise from north) and speeds::

    v = (s_h sin c, s_h cos c, s_v)

``None`` when a speed is unknown, or the course is unknown at a speed that needs one.
"""

from __future__ import annotations

import enum
import itertools
import logging
import math
import operator
from collections import OrderedDict, deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from ridsafe.common import frames
from ridsafe.common.frames import GeodeticOrigin
from ridsafe.common.jit import jit
from ridsafe.common.messages import (
    FIRST_OPTIONAL_COLUMN,
    OBSERVATION_COLUMNS,
    Observation,
    ObservationRows,
    Vec3,
)
from ridsafe.gcs.config import GcsConfig
from ridsafe.gcs.pipeline_api import ObservedClaim, readonly

logger = logging.getLogger(__name__)

GroupKey = tuple[str, float]
#: Below this claimed ground speed an unknown course still gives a (vertical-only) velocity.
HOVER_SPEED_M_S = 0.05
_TIME_EPS_S = 1e-9


class RejectReason(enum.Enum):
    EMPTY_ID = "empty_id"
    NON_FINITE = "non_finite"
    LAT_LON_RANGE = "lat_lon_range"
    RSSI_RANGE = "rssi_range"
    ALTITUDE_RANGE = "altitude_range"
    DISTANCE_RANGE = "distance_range"
    FUTURE_TIME = "future_time"
    TOO_OLD = "too_old"
    DUPLICATE = "duplicate"
    LATE = "late"
    TOO_MANY_GROUPS = "too_many_groups"


# --- checks (pure functions) ---------------------------------------------------------------


_REQUIRED_FLOATS = operator.attrgetter(*OBSERVATION_COLUMNS[:FIRST_OPTIONAL_COLUMN])
_OPTIONAL_FLOATS = operator.attrgetter(*OBSERVATION_COLUMNS[FIRST_OPTIONAL_COLUMN:])


def _finite(obs: Observation) -> bool:
    """Every float of the report finite (the optional ones when present)?"""
    return all(map(math.isfinite, _REQUIRED_FLOATS(obs))) and all(
        v is None or math.isfinite(v) for v in _OPTIONAL_FLOATS(obs)
    )


def check_values(obs: Observation, config: GcsConfig) -> RejectReason | None:
    """The first reason the report's own values are implausible, or None."""
    if not obs.uas_id.strip("\x00 "):
        return RejectReason.EMPTY_ID
    if not _finite(obs):
        return RejectReason.NON_FINITE
    for lat, lon in ((obs.rx_lat_deg, obs.rx_lon_deg), (obs.claimed_lat_deg, obs.claimed_lon_deg)):
        if abs(lat) > 90.0 or abs(lon) > 180.0:
            return RejectReason.LAT_LON_RANGE
    if not config.rssi_min_dbm <= obs.rssi_dbm <= config.rssi_max_dbm:
        return RejectReason.RSSI_RANGE
    for alt in (obs.rx_alt_m, obs.claimed_alt_m):
        if not config.alt_min_m <= alt <= config.alt_max_m:
            return RejectReason.ALTITUDE_RANGE
    return None


def check_time(t_s: float, now_s: float, config: GcsConfig) -> RejectReason | None:
    """FUTURE_TIME / TOO_OLD for a receive time ``t_s`` seen at GCS sim time ``now_s``."""
    if t_s > now_s + config.future_tolerance_s:
        return RejectReason.FUTURE_TIME
    if t_s < now_s - config.history_window_s:
        return RejectReason.TOO_OLD
    return None


def claimed_velocity_enu(obs: Observation) -> Vec3 | None:
    """ENU velocity the broadcast claims (see the module docstring), or None."""
    return _claimed_velocity(
        obs.claimed_course_deg, obs.claimed_speed_horizontal_m_s, obs.claimed_speed_vertical_m_s
    )


def _claimed_velocity(
    course_deg: float | None, speed_h: float | None, speed_v: float | None
) -> Vec3 | None:
    if speed_h is None or speed_v is None:
        return None
    if course_deg is None:
        return (0.0, 0.0, speed_v) if speed_h < HOVER_SPEED_M_S else None
    course = math.radians(course_deg)
    return (speed_h * math.sin(course), speed_h * math.cos(course), speed_v)


def _none_if_nan(value: float) -> float | None:
    return None if math.isnan(value) else value


def plain_rows(rows: ObservationRows, now_s: float, config: GcsConfig) -> list[bool]:
    """Per row of ``rows``: True where ``check_values`` and ``check_time`` (at GCS sim time
    ``now_s``) find nothing, the values checked in one compiled pass."""
    plain = np.empty(len(rows), dtype=np.bool_)
    _plain_values(
        rows.values,
        now_s - config.history_window_s,
        now_s + config.future_tolerance_s,
        config.rssi_min_dbm,
        config.rssi_max_dbm,
        config.alt_min_m,
        config.alt_max_m,
        plain,
    )
    named = {uas_id for uas_id in set(rows.uas_id) if uas_id.strip("\x00 ")}
    flags: list[bool] = plain.tolist()
    if len(named) < len(set(rows.uas_id)):
        flags = [flag and uas_id in named for flag, uas_id in zip(flags, rows.uas_id, strict=True)]
    return flags


@jit
def _plain_values(
    values: NDArray[np.float64],
    oldest_t_s: float,
    newest_t_s: float,
    rssi_min_dbm: float,
    rssi_max_dbm: float,
    alt_min_m: float,
    alt_max_m: float,
    out: NDArray[np.bool_],
) -> None:
    """``check_values`` (all but the id) and ``check_time`` of each row, into ``out``."""
    for r in range(values.shape[0]):
        finite = True
        for c in range(values.shape[1]):
            v = values[r, c]
            if np.isinf(v) or (c < FIRST_OPTIONAL_COLUMN and np.isnan(v)):
                finite = False
        t_s, rx_alt, c_alt, rssi = values[r, 0], values[r, 3], values[r, 6], values[r, 8]
        out[r] = (
            finite
            and abs(values[r, 1]) <= 90.0
            and abs(values[r, 2]) <= 180.0
            and abs(values[r, 4]) <= 90.0
            and abs(values[r, 5]) <= 180.0
            and rssi_min_dbm <= rssi <= rssi_max_dbm
            and alt_min_m <= rx_alt <= alt_max_m
            and alt_min_m <= c_alt <= alt_max_m
            and oldest_t_s <= t_s <= newest_t_s
        )


# --- grouping --------------------------------------------------------------------------------


#: One reception as a group keeps it: receive time, receiver ENU x, y, z, RSSI, system id.
_Reception = tuple[float, float, float, float, float, int]


@dataclass(slots=True)
class _Group:
    """One open broadcast: its claim and its receptions so far, each kept as it comes as one
    ``_Reception`` (``claims_of`` turns every group's into arrays at once)."""

    uas_id: str
    rid_timestamp_s: float
    opened_s: float
    claimed_geodetic: Vec3  # (lat deg, lon deg, alt m) of the first report
    claimed_p_enu_m: Vec3  # the same in ENU
    claimed_v_enu_m_s: Vec3 | None
    rows: list[_Reception] = field(default_factory=list)
    first_t_s: float = math.inf
    heard_by: set[int] = field(default_factory=set)

    def add(self, rx_sysid: int, t_s: float, rx_p_enu_m: Vec3, rssi_dbm: float) -> None:
        east, north, up = rx_p_enu_m
        self.rows.append((t_s, east, north, up, rssi_dbm, rx_sysid))
        self.heard_by.add(rx_sysid)
        if t_s < self.first_t_s:  # noqa: PLR1730 (min() costs a call per report)
            self.first_t_s = t_s


_T, _X, _Y, _Z, _RSSI, _SYSID = range(6)
_NO_VELOCITY = (math.nan, math.nan, math.nan)  # a row of ``claims_of``'s velocities, unused


def claim_order(claim: ObservedClaim) -> tuple[float, str]:
    """The order claims go to the pipeline in: first reception time, then transmitter id."""
    return claim.t_s, claim.uas_id


def claims_of(groups: Sequence[_Group]) -> list[ObservedClaim]:
    """The observed claims of ``groups``, receptions sorted by receiver id: every group's
    rows stacked, sorted by (group, receiver) and cut into read-only columns, then sliced
    per claim, the claimed positions and velocities likewise (a handful of numpy calls per
    cycle, none per reception or claim)."""
    if not groups:
        return []
    sizes = [len(g.rows) for g in groups]
    ends = list(itertools.accumulate(sizes))
    stacked = np.array([row for g in groups for row in g.rows], dtype=np.float64)
    sysid = stacked[:, _SYSID].astype(np.int64)
    group = np.repeat(np.arange(len(groups), dtype=np.int64), sizes)
    order = np.argsort((group << 32) | sysid)  # (group, receiver): system ids are < 2^32
    stacked = stacked[order]
    sysid = _frozen(sysid[order])
    t_s = _frozen(np.ascontiguousarray(stacked[:, _T]))
    rssi = _frozen(np.ascontiguousarray(stacked[:, _RSSI]))
    rx_p = _frozen(np.ascontiguousarray(stacked[:, _X : _Z + 1]))
    # Every claimed position and velocity in one read-only array each, a row per claim.
    claimed_p = readonly([g.claimed_p_enu_m for g in groups])
    claimed_v = readonly([g.claimed_v_enu_m_s or _NO_VELOCITY for g in groups])
    claims = []
    for j, (g, end, size) in enumerate(zip(groups, ends, sizes, strict=True)):
        rows = slice(end - size, end)
        claim = ObservedClaim(
            uas_id=g.uas_id,
            rid_timestamp_s=g.rid_timestamp_s,
            claimed_p_enu_m=claimed_p[j],
            claimed_v_enu_m_s=None if g.claimed_v_enu_m_s is None else claimed_v[j],
            rx_sysid=sysid[rows],
            rx_p_enu_m=rx_p[rows],
            rx_t_s=t_s[rows],
            rssi_dbm=rssi[rows],
        )
        claim.__dict__["t_s"] = g.first_t_s  # its cached ``t_s`` (the same value)
        claims.append(claim)
    return claims


_A = TypeVar("_A", bound=np.ndarray)


def _frozen(arr: _A) -> _A:
    """``arr`` (freshly built, not shared) made read-only in place."""
    arr.setflags(write=False)
    return arr


def group_key(uas_id: str, rid_timestamp_s: float) -> GroupKey:
    """Key of one broadcast (the timestamp rounded to 1 ms: it travels as a float32)."""
    rounded = _ROUNDED_TO_MS.get(rid_timestamp_s)
    if rounded is None:  # each broadcast's timestamp comes once per receiver: round it once
        if len(_ROUNDED_TO_MS) >= _ROUNDED_TO_MS_SIZE:
            _ROUNDED_TO_MS.clear()
        rounded = _ROUNDED_TO_MS[rid_timestamp_s] = round(rid_timestamp_s, 3)
    return uas_id, rounded


#: Timestamps -> ``round(t, 3)`` lately (Python's exact decimal rounding costs as much as the
#: rest of filing a report).
_ROUNDED_TO_MS: dict[float, float] = {}
_ROUNDED_TO_MS_SIZE = 4096


@dataclass
class IngestCounters:
    accepted: int = 0
    transmissions: int = 0
    evicted_transmitters: int = 0
    rejected: dict[RejectReason, int] = field(default_factory=dict)

    def as_dict(self) -> dict[str, int]:
        out = {
            "observations_accepted": self.accepted,
            "transmissions_closed": self.transmissions,
            "transmitters_evicted": self.evicted_transmitters,
        }
        out.update({f"rejected_{r.value}": n for r, n in sorted(self.rejected.items(), key=str)})
        return out


class Ingest:
    """Validated receptions grouped by broadcast into observed claims, and a bounded
    history per transmitter.

    ``add(now_s, rx_sysid, obs)`` takes one report (``rx_sysid``: the MAVLink system id that
    sent it) and returns None if kept, else why not. ``close_due(now_s)`` returns the
    claims whose window has passed, oldest first, and records them in the history.
    """

    def __init__(self, config: GcsConfig, origin: GeodeticOrigin) -> None:
        self.config = config
        self.origin = origin
        self.counters = IngestCounters()
        self._open: dict[GroupKey, _Group] = {}
        self._closed: dict[GroupKey, float] = {}  # key -> when it closed (sim time)
        self._history: OrderedDict[str, deque[ObservedClaim]] = OrderedDict()
        #: per receiver system id: its last (lat, lon, alt) and their ENU conversion
        self._last_rx: dict[int, tuple[tuple[float, float, float], tuple[float, float, float]]] = {}

    @property
    def open_groups(self) -> int:
        return len(self._open)

    @property
    def transmitters(self) -> tuple[str, ...]:
        """Claimed ids with a history, least recently updated first."""
        return tuple(self._history)

    def history(self, uas_id: str) -> tuple[ObservedClaim, ...]:
        """Recent closed claims of ``uas_id``, oldest first (at most the configured)."""
        return tuple(self._history.get(uas_id, ()))

    def add(self, now_s: float, rx_sysid: int, obs: Observation) -> RejectReason | None:
        reason = check_values(obs, self.config) or check_time(obs.t_s, now_s, self.config)
        if reason is None:
            reason = self._group(
                now_s,
                rx_sysid,
                obs.uas_id,
                obs.t_s,
                (obs.rx_lat_deg, obs.rx_lon_deg, obs.rx_alt_m),
                (obs.claimed_lat_deg, obs.claimed_lon_deg, obs.claimed_alt_m),
                obs.rid_timestamp_s,
                obs.rssi_dbm,
                obs,
            )
        return self._count(reason)

    def add_rows(
        self, now_s: float, rx_sysid: int, rows: ObservationRows
    ) -> list[tuple[str, RejectReason]]:
        """``add`` of each row of ``rows`` (one receiver's reports), in order, the value and
        time checks made for all rows at once; returns (claimed id, why) of the rows not
        kept."""
        plain = plain_rows(rows, now_s, self.config)
        rejected = []
        for i, (row, uas_id) in enumerate(zip(rows.values.tolist(), rows.uas_id, strict=True)):
            if plain[i]:
                t_s, rx_lat, rx_lon, rx_alt, c_lat, c_lon, c_alt, rid_ts, rssi = row[:9]
                reason = self._count(
                    self._group(
                        now_s,
                        rx_sysid,
                        uas_id,
                        t_s,
                        (rx_lat, rx_lon, rx_alt),
                        (c_lat, c_lon, c_alt),
                        rid_ts,
                        rssi,
                        row,
                    )
                )
            else:
                reason = self.add(now_s, rx_sysid, rows.observation(i))
            if reason is not None:
                rejected.append((uas_id, reason))
        return rejected

    def _count(self, reason: RejectReason | None) -> RejectReason | None:
        if reason is None:
            self.counters.accepted += 1
        else:
            self.counters.rejected[reason] = self.counters.rejected.get(reason, 0) + 1
        return reason

    def _group(
        self,
        now_s: float,
        rx_sysid: int,
        uas_id: str,
        t_s: float,
        rx_geodetic: Vec3,
        claimed_geodetic: Vec3,
        rid_timestamp_s: float,
        rssi_dbm: float,
        source: Observation | list[float],
    ) -> RejectReason | None:
        """File a report whose values passed their checks under its broadcast (``source``:
        the report, or its row of ``ObservationRows``, for the claimed velocity)."""
        key = group_key(uas_id, rid_timestamp_s)
        group = self._open.get(key)
        rx_p = self._rx_enu(rx_sysid, rx_geodetic)
        if group is not None and group.claimed_geodetic == claimed_geodetic:
            claimed_p = group.claimed_p_enu_m  # every receiver reports the same claim
        else:
            claimed_p = frames.geodetic_to_enu_point(self.origin, *claimed_geodetic)
        limit = self.config.max_distance_m
        if math.hypot(*rx_p) > limit or math.hypot(*claimed_p) > limit:
            return RejectReason.DISTANCE_RANGE
        if key in self._closed:
            return RejectReason.LATE
        if group is None:
            if len(self._open) >= self.config.max_open_groups:
                return RejectReason.TOO_MANY_GROUPS
            if isinstance(source, Observation):
                velocity = claimed_velocity_enu(source)
            else:
                course, speed_h, speed_v = map(_none_if_nan, source[FIRST_OPTIONAL_COLUMN:])
                velocity = _claimed_velocity(course, speed_h, speed_v)
            group = _Group(uas_id, rid_timestamp_s, now_s, claimed_geodetic, claimed_p, velocity)
            self._open[key] = group
        elif rx_sysid in group.heard_by:
            return RejectReason.DUPLICATE
        group.add(rx_sysid, t_s, rx_p, rssi_dbm)
        return None

    def _rx_enu(self, rx_sysid: int, geodetic: Vec3) -> Vec3:
        """The receiver's ENU position: a companion reports every frame it heard in one step
        from one position, so the last conversion per receiver is reused when it matches."""
        last = self._last_rx.get(rx_sysid)
        if last is not None and last[0] == geodetic:
            return last[1]
        p_enu_m = frames.geodetic_to_enu_point(self.origin, *geodetic)
        self._last_rx[rx_sysid] = (geodetic, p_enu_m)
        return p_enu_m

    def close_due(self, now_s: float) -> list[ObservedClaim]:
        window = self.config.group_window_s
        due = [k for k, g in self._open.items() if now_s - g.opened_s >= window - _TIME_EPS_S]
        closed = claims_of([self._open.pop(k) for k in due])
        closed.sort(key=claim_order)
        for key in due:
            self._closed[key] = now_s
        for claim in closed:
            self._remember(claim)
        self.counters.transmissions += len(closed)
        self._forget_closed_keys(now_s)
        return closed

    def _remember(self, claim: ObservedClaim) -> None:
        uas_id = claim.uas_id
        history = self._history.get(uas_id)
        if history is None:
            history = deque(maxlen=self.config.history_per_transmitter)
            self._history[uas_id] = history
            if len(self._history) > self.config.max_transmitters:
                evicted, _ = self._history.popitem(last=False)
                self.counters.evicted_transmitters += 1
                logger.info("history of %r evicted (max_transmitters reached)", evicted)
        self._history.move_to_end(uas_id)
        history.append(claim)

    def _forget_closed_keys(self, now_s: float) -> None:
        horizon = now_s - self.config.history_window_s
        stale = []
        for key, closed_s in self._closed.items():  # in closing order, so oldest first
            if closed_s >= horizon:
                break
            stale.append(key)
        for key in stale:
            del self._closed[key]


class RateLimitedLog:
    """At most one WARNING per key and ``interval_s`` of sim time; the rest go to DEBUG and
    are summarised ("n more since") in the next warning."""

    def __init__(self, log: logging.Logger, interval_s: float) -> None:
        self._log = log
        self._interval_s = interval_s
        self._last: dict[str, float] = {}
        self._suppressed: dict[str, int] = {}

    def warn(self, now_s: float, key: str, message: str) -> None:
        last = self._last.get(key)
        if last is not None and now_s - last < self._interval_s:
            self._suppressed[key] = self._suppressed.get(key, 0) + 1
            self._log.debug("%s", message)
            return
        more = self._suppressed.pop(key, 0)
        suffix = f" ({more} more since the last warning)" if more else ""
        self._last[key] = now_s
        self._log.warning("%s%s", message, suffix)
