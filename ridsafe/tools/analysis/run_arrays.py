"""A run log as arrays: what the metrics and the time series read from one MCAP file.

:func:`load_run` reads the records the metrics need in one streaming pass (``read_records``)
and stacks them into read-only numpy arrays (:class:`RunLog`): truth ``/truth/vehicles``
(:class:`Truth`), ``/run/meta`` (benign aircraft and goals, spoofer, NMAC threshold, arrival
radius), ``/gcs/alerts``, ``/gcs/tracks``, ``/gcs/unsafe_regions`` (:class:`Regions`),
``/gcs/cycle``, ``/companion/decisions`` and ``/run/end``. "The spoofer" is ``/run/meta``'s
``spoofer`` (sysid for truth, serial for the GCS records).

Truth between samples (at GCS record times) is linearly interpolated; ``armed`` is taken from
the sample before; NaN / False further than ``MAX_EXTRAPOLATION_S`` outside the samples.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ridsafe.common import topics
from ridsafe.common.adversary import AdversaryRole
from ridsafe.tools.runlog.reader import LogReadError, read_records

__all__ = [
    "DEFAULT_ARRIVAL_RADIUS_M",
    "DEFAULT_NMAC_THRESHOLD_M",
    "DETECTION_RECEIVERS",
    "Regions",
    "RunLog",
    "Truth",
    "benign_serials",
    "heard_by_s",
    "load_run",
]

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
IntArray = NDArray[np.int64]

DEFAULT_NMAC_THRESHOLD_M = 50.0
DEFAULT_ARRIVAL_RADIUS_M = 10.0
#: Detection delay is measured from when this many aircraft had heard the spoofer.
DETECTION_RECEIVERS = 4
#: Truth is held this far beyond its first/last sample when interpolating; NaN further out.
MAX_EXTRAPOLATION_S = 0.2

_TOPICS = (
    topics.RUN_META,
    topics.RUN_END,
    topics.TRUTH,
    topics.ALERTS,
    topics.TRACKS,
    topics.REGIONS,
    topics.GCS_CYCLE,
    topics.DECISIONS,
    topics.SIM_EVENTS,
)


def _freeze(*arrays: NDArray[Any]) -> None:
    for array in arrays:
        array.setflags(write=False)


@dataclass(frozen=True, eq=False)
class Truth:
    """True states: ``t_s`` (T,), ``sysid`` (N,), ``p_enu_m`` (T, N, 3) (NaN = unknown),
    ``armed`` (T, N)."""

    t_s: FloatArray
    sysid: IntArray
    p_enu_m: FloatArray
    armed: BoolArray

    def __post_init__(self) -> None:
        _freeze(self.t_s, self.sysid, self.p_enu_m, self.armed)

    def column(self, sysid: int) -> int | None:
        hits = np.flatnonzero(self.sysid == sysid)
        return int(hits[0]) if hits.size else None

    def at(self, t_query_s: FloatArray) -> tuple[FloatArray, BoolArray]:
        """Positions (Q, N, 3) linearly interpolated at ``t_query_s`` (Q,) and armed (Q, N)
        from the sample before; NaN / False beyond ``MAX_EXTRAPOLATION_S`` of the samples."""
        tq = np.asarray(t_query_s, dtype=np.float64)
        n = self.sysid.size
        if self.t_s.size == 0:
            return np.full((tq.size, n, 3), np.nan), np.zeros((tq.size, n), dtype=bool)
        last = self.t_s.size - 1
        right = np.searchsorted(self.t_s, tq, side="right")
        i0 = np.clip(right - 1, 0, last)
        i1 = np.clip(right, 0, last)
        span = self.t_s[i1] - self.t_s[i0]
        safe_span = np.where(span > 0.0, span, 1.0)
        w = np.clip(np.where(span > 0.0, (tq - self.t_s[i0]) / safe_span, 0.0), 0.0, 1.0)
        p = self.p_enu_m[i0] * (1.0 - w)[:, None, None] + self.p_enu_m[i1] * w[:, None, None]
        armed = self.armed[i0].copy()
        outside = (tq < self.t_s[0] - MAX_EXTRAPOLATION_S) | (
            tq > self.t_s[-1] + MAX_EXTRAPOLATION_S
        )
        p[outside] = np.nan
        armed[outside] = False
        return p, armed


@dataclass(frozen=True, eq=False)
class Regions:
    """Unsafe-region records: ``t_s`` (R,), ``uas_id`` (R,), ``center_enu_m`` (R, 3),
    ``cov_enu_m2`` (R, 3, 3), ``chi2`` (R,), ``flags`` (R,) (``messages.RegionFlags``)."""

    t_s: FloatArray
    uas_id: NDArray[np.str_]
    center_enu_m: FloatArray
    cov_enu_m2: FloatArray
    chi2: FloatArray
    flags: NDArray[np.int64]

    def __post_init__(self) -> None:
        _freeze(self.t_s, self.uas_id, self.center_enu_m, self.cov_enu_m2, self.chi2, self.flags)

    def select(self, which: NDArray[Any]) -> Regions:
        """The records picked by a boolean mask or an index array."""
        return Regions(
            self.t_s[which],
            self.uas_id[which],
            self.center_enu_m[which],
            self.cov_enu_m2[which],
            self.chi2[which],
            self.flags[which],
        )


@dataclass(frozen=True, eq=False)
class RunLog:
    """Everything the metrics read from one run log (arrays read-only)."""

    path: Path
    meta: Mapping[str, Any]
    end: Mapping[str, Any] | None
    truth: Truth
    benign_sysids: tuple[int, ...]
    goals_enu_m: Mapping[int, tuple[float, float, float]]
    spoofer_sysid: int | None
    spoofer_serial: str | None
    nmac_threshold_m: float
    arrival_radius_m: float
    alerts: tuple[tuple[float, Mapping[str, Any]], ...]
    track_t_s: FloatArray
    track_uas_id: NDArray[np.str_]
    track_p_enu_m: FloatArray
    regions: Regions
    gcs_compute_ms: FloatArray
    decision_compute_ms: FloatArray
    spoofer_heard_s: float | None = None  # heard by DETECTION_RECEIVERS aircraft
    autopilot_failsafes: int = 0  # /sim/events records (companion-loss failsafes)
    #: serial -> (times, |claimed - true| m) of every spoofer, from the truth channel's
    #: ``adversaries`` (``adversary_metrics``: when the lie can hurt)
    spoofer_lies: Mapping[str, tuple[FloatArray, FloatArray]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        _freeze(
            self.track_t_s,
            self.track_uas_id,
            self.track_p_enu_m,
            self.gcs_compute_ms,
            self.decision_compute_ms,
        )


def load_run(path: str | os.PathLike[str]) -> RunLog:
    """Read the records the metrics need from ``path`` (one streaming pass)."""
    by_topic: dict[str, list[tuple[float, dict[str, Any]]]] = {name: [] for name in _TOPICS}
    for topic, t_s, record in read_records(path, topics=_TOPICS):
        by_topic[topic].append((t_s, record))
    if not any(by_topic.values()):
        raise LogReadError(f"{path}: no run-log records (none of {', '.join(_TOPICS)})")
    metas = by_topic[topics.RUN_META]
    if not metas:
        logger.warning("%s: no %s record: benign set from truth, no goals", path, topics.RUN_META)
    meta: Mapping[str, Any] = metas[0][1] if metas else {}
    ends = by_topic[topics.RUN_END]
    truth = _stack_truth(by_topic[topics.TRUTH])
    spoofer = meta.get("spoofer") if isinstance(meta.get("spoofer"), Mapping) else None
    spoofer_sysid = _spoofer_sysid(spoofer, by_topic[topics.TRUTH])
    aircraft = [a for a in meta.get("aircraft") or [] if isinstance(a, Mapping)]
    if aircraft:
        benign = tuple(int(a["sysid"]) for a in aircraft)
    else:
        benign = tuple(int(s) for s in truth.sysid if int(s) != spoofer_sysid)
    goals = {int(a["sysid"]): _vec3(a["goal_enu_m"]) for a in aircraft if "goal_enu_m" in a}
    track_t, track_id, track_p = _tracks(by_topic[topics.TRACKS])
    return RunLog(
        path=Path(path),
        meta=meta,
        end=ends[-1][1] if ends else None,
        truth=truth,
        benign_sysids=benign,
        goals_enu_m=goals,
        spoofer_sysid=spoofer_sysid,
        spoofer_serial=None if spoofer is None else str(spoofer.get("serial")),
        nmac_threshold_m=float(meta.get("nmac_threshold_m") or DEFAULT_NMAC_THRESHOLD_M),
        arrival_radius_m=_arrival_radius(meta),
        alerts=tuple(sorted(by_topic[topics.ALERTS], key=lambda item: item[0])),
        track_t_s=track_t,
        track_uas_id=track_id,
        track_p_enu_m=track_p,
        regions=_regions(by_topic[topics.REGIONS]),
        gcs_compute_ms=_compute_ms(by_topic[topics.GCS_CYCLE]),
        decision_compute_ms=_compute_ms(by_topic[topics.DECISIONS]),
        spoofer_heard_s=None if spoofer_sysid is None else heard_by_s(path, spoofer_sysid),
        autopilot_failsafes=len(by_topic[topics.SIM_EVENTS]),
        spoofer_lies=_spoofer_lies(by_topic[topics.TRUTH]),
    )


def _spoofer_lies(
    truth_rows: list[tuple[float, dict[str, Any]]],
) -> dict[str, tuple[FloatArray, FloatArray]]:
    """serial -> (times, |claimed - true| m) from the truth records' ``adversaries``."""
    times: dict[str, list[float]] = {}
    lies: dict[str, list[float]] = {}
    for t_s, record in truth_rows:
        p = record.get("p_enu_m")
        sysids = record.get("sysid") or []
        for item in record.get("adversaries") or ():
            liar = item.get("role") == AdversaryRole.SPOOFER
            if p is None or not liar or item["sysid"] not in sysids:
                continue
            true = np.asarray(p[sysids.index(item["sysid"])], dtype=np.float64)
            lie = float(np.linalg.norm(np.asarray(item["claimed_p_enu_m"]) - true))
            times.setdefault(item["serial"], []).append(t_s)
            lies.setdefault(item["serial"], []).append(lie)
    return {k: (np.array(times[k]), np.array(lies[k])) for k in times}


def benign_serials(meta: Mapping[str, Any]) -> dict[str, int]:
    """Serial -> sysid of the benign aircraft of a ``/run/meta`` record."""
    aircraft = meta.get("aircraft")
    if not isinstance(aircraft, list):
        return {}
    return {
        str(a["serial"]): int(a["sysid"])
        for a in aircraft
        if isinstance(a, Mapping) and "serial" in a and "sysid" in a
    }


def heard_by_s(
    path: str | os.PathLike[str], sender_sysid: int, receivers: int = DETECTION_RECEIVERS
) -> float | None:
    """When ``receivers`` distinct aircraft had heard a broadcast of ``sender_sysid``.

    ``/radio/receptions`` has one writer, the sim, in time order: the scan stops there (a
    second pass that reads the first seconds of the log, not the whole of it)."""
    heard: set[int] = set()
    for _topic, t_s, record in read_records(path, topics=(topics.RADIO_RX,)):
        for item in record.get("items") or ():
            if isinstance(item, Mapping) and item.get("sender") == sender_sysid:
                heard.add(int(item["receiver"]))
                if len(heard) >= receivers:
                    return t_s
    return None


def _vec3(value: Sequence[float]) -> tuple[float, float, float]:
    return (float(value[0]), float(value[1]), float(value[2]))


def _spoofer_sysid(
    spoofer: Mapping[str, Any] | None, truth_rows: list[tuple[float, dict[str, Any]]]
) -> int | None:
    if spoofer is not None and spoofer.get("sysid") is not None:
        return int(spoofer["sysid"])
    for _t, row in truth_rows[:1]:
        if row.get("spoofer_sysid") is not None:
            return int(row["spoofer_sysid"])
    return None


def _arrival_radius(meta: Mapping[str, Any]) -> float:
    scenario = meta.get("scenario")
    for section in ("companion", "planner"):
        config = scenario.get(section) if isinstance(scenario, Mapping) else None
        if isinstance(config, Mapping) and config.get("arrival_radius_m") is not None:
            return float(config["arrival_radius_m"])
    return DEFAULT_ARRIVAL_RADIUS_M


def _stack_truth(rows: list[tuple[float, dict[str, Any]]]) -> Truth:
    if not rows:
        empty = np.zeros(0)
        return Truth(empty, np.zeros(0, np.int64), np.zeros((0, 0, 3)), np.zeros((0, 0), bool))
    rows = sorted(rows, key=lambda row: row[0])
    t = np.array([t for t, _ in rows], dtype=np.float64)
    first = [int(s) for s in rows[0][1]["sysid"]]
    if all([int(s) for s in r["sysid"]] == first for _, r in rows):
        n = len(first)
        p = np.array([r["p_enu_m"] for _, r in rows], dtype=np.float64).reshape(t.size, n, 3)
        armed = np.array([r.get("armed") or [False] * n for _, r in rows], dtype=bool)
        return Truth(t, np.array(first, dtype=np.int64), p, armed.reshape(t.size, n))
    # The vehicle set changed between samples: one column per sysid ever seen.
    sysids = sorted({int(s) for _, r in rows for s in r["sysid"]})
    column = {s: k for k, s in enumerate(sysids)}
    p = np.full((t.size, len(sysids), 3), np.nan)
    armed = np.zeros((t.size, len(sysids)), dtype=bool)
    for k, (_, r) in enumerate(rows):
        flags = r.get("armed") or [False] * len(r["sysid"])
        for s, pos, flag in zip(r["sysid"], r["p_enu_m"], flags, strict=True):
            p[k, column[int(s)]] = np.array(pos, dtype=np.float64)
            armed[k, column[int(s)]] = bool(flag)
    return Truth(t, np.array(sysids, dtype=np.int64), p, armed)


def _tracks(
    rows: list[tuple[float, dict[str, Any]]],
) -> tuple[FloatArray, NDArray[np.str_], FloatArray]:
    rows = sorted(rows, key=lambda row: row[0])
    t = np.array([t for t, _ in rows], dtype=np.float64)
    ids = np.array([str(r["uas_id"]) for _, r in rows], dtype=np.str_)
    p = np.array([r["p_enu_m"] for _, r in rows], dtype=np.float64).reshape(len(rows), 3)
    return t, ids, p


def _regions(rows: list[tuple[float, dict[str, Any]]]) -> Regions:
    rows = sorted(rows, key=lambda row: row[0])
    return Regions(
        t_s=np.array([t for t, _ in rows], dtype=np.float64),
        uas_id=np.array([str(r["uas_id"]) for _, r in rows], dtype=np.str_),
        center_enu_m=np.array([r["center_enu_m"] for _, r in rows], dtype=np.float64).reshape(
            len(rows), 3
        ),
        cov_enu_m2=np.array([r["cov_enu_m2"] for _, r in rows], dtype=np.float64).reshape(
            len(rows), 3, 3
        ),
        chi2=np.array([r["chi2_threshold"] for _, r in rows], dtype=np.float64),
        flags=np.array([int(r.get("flags", 0)) for _, r in rows], dtype=np.int64),
    )


def _compute_ms(rows: list[tuple[float, dict[str, Any]]]) -> FloatArray:
    values = np.array([r.get("compute_ms") for _, r in rows], dtype=np.float64)
    return values[np.isfinite(values)]
