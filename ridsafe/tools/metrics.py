r"""Run metrics, computed from the run log (MCAP) alone (DESIGN.md section 7, paper Tables 2-3).

Inputs are the records of ``ridsafe.common.topics``: truth ``/truth/vehicles`` (10 Hz),
``/run/meta`` (benign aircraft and goals, spoofer, NMAC threshold), ``/gcs/alerts``,
``/gcs/tracks``, ``/gcs/unsafe_regions``, ``/gcs/cycle``, ``/companion/decisions``,
``/run/end``. "The spoofer" is ``/run/meta``'s ``spoofer`` (sysid for truth, serial for the
GCS records). A quantity that does not apply is ``None`` (no spoofer, no alert, no region...).

Airborne. An aircraft counts as airborne at a truth sample when it is armed and its true
height ``z_enu >= min_height_m`` (1 m; depots and delivery sites are at z = 0). Aircraft
sharing a depot start metres apart on the ground; pairs with an aircraft on the ground are no
encounter. Truth between samples (at GCS record times) is linearly interpolated; ``armed`` is
taken from the sample before.

Entry events (used by every NMAC variant). For one pair, a sample is *inside* (distance
``d < d_nmac``, or the aircraft inside the ellipsoid) or *separated* (``d >= d_nmac``, or
outside); NaN is neither. A run of samples between two separated samples is one episode; the
episode is one event if at some sample of it the pair is inside and both are airborne. So a
pass at 40 m is one event however many samples it spans, and approach - separate - re-approach
is two. (Two aircraft that take off together less than ``d_nmac`` apart count once, when
both are above ``min_height_m``.)

- ``nmac_benign_benign``: entry events over all benign pairs, 3D true distance, threshold
  ``nmac_threshold_m`` from ``/run/meta`` (50 m).
- ``nmac_benign_spoofer``: the same for (benign, true spoofer) pairs. None without spoofer.
- ``unsafe_violations``: for every ``/gcs/unsafe_regions`` record (one per GCS update and
  region), each benign aircraft's true position ``x`` at the record time is inside when
  ``(x - c)^T P^-1 (x - c) <= chi2_threshold``; entry events per (aircraft, region uas_id)
  over that region's updates (the first update finding an aircraft inside is an entry).
  None when the log has no region at all (trust-RID publishes none).
- ``containment_rate`` (LCR): over the spoofer's regions at or after the first alert, the
  fraction whose ellipsoid contains the spoofer's true position at the record time.
- ``rmse_m`` / ``mae_m``: over the spoofer's ``/gcs/tracks`` records at or after the alert,
  ``e = |p_est - p_true|`` (3D); RMSE = sqrt(mean e^2), MAE = mean e.
- ``max_ellipsoid_radius_m``: max over the spoofer's regions of the largest semi-axis
  ``sqrt(chi2_threshold * lambda_max(P))``.
- ``min_distance_to_spoofer_m``: min over truth samples and airborne benign aircraft of the
  3D true distance to the spoofer.
- ``goal_reached_fraction``: fraction of the benign aircraft of ``/run/meta`` whose true
  horizontal position came within the arrival radius of ``goal_enu_m`` (``/run/meta``'s
  ``scenario.companion.arrival_radius_m``, else ``scenario.planner.arrival_radius_m``, else
  10 m).
- ``alert_time_s``: time of the first ``raised`` alert for the spoofer's serial.
- ``detection_delay_s``: ``alert_time_s`` minus the time the spoofer's broadcasts had been
  heard by ``DETECTION_RECEIVERS`` (4) distinct aircraft (``/radio/receptions``, any RID
  message type): how long the GCS needed once it could in principle localise. Negative when
  it alerted earlier; None without alert or without such receptions.
- ``false_alerts``: ``raised`` alerts for any uas_id but the spoofer's serial.
- ``wall_clock_s``: ``/run/end``'s wall clock; None when the run has no end record.
- ``gcs_compute_s``: sum of ``/gcs/cycle`` ``compute_ms`` / 1000; ``gcs_update_p99_ms``
  and ``planner_decision_p99_ms`` (``/companion/decisions``): 99th percentile of
  ``compute_ms``, linear interpolation between order statistics (numpy's default, type 7).

:func:`metric_series` gives the same quantities over time (the paper's Fig. 3).
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ridsafe.common import topics
from ridsafe.common.ellipsoid import mahalanobis2
from ridsafe.tools.recorder import LogReadError, read_records

__all__ = [
    "METRIC_KEYS",
    "MetricSeries",
    "RunLog",
    "Truth",
    "compute_metrics",
    "count_entry_events",
    "load_run",
    "metric_series",
]

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
IntArray = NDArray[np.int64]
Metrics = dict[str, float | int | None]

DEFAULT_NMAC_THRESHOLD_M = 50.0
DEFAULT_ARRIVAL_RADIUS_M = 10.0
DEFAULT_MIN_HEIGHT_M = 1.0
#: Detection delay is measured from when this many aircraft had heard the spoofer.
DETECTION_RECEIVERS = 4
#: Truth is held this far beyond its first/last sample when interpolating; NaN further out.
MAX_EXTRAPOLATION_S = 0.2
#: Pairs per block in the pairwise distance computation (bounds memory for 256 aircraft).
_PAIR_BLOCK = 2048

METRIC_KEYS: tuple[str, ...] = (
    "nmac_benign_benign",
    "nmac_benign_spoofer",
    "unsafe_violations",
    "containment_rate",
    "rmse_m",
    "mae_m",
    "max_ellipsoid_radius_m",
    "min_distance_to_spoofer_m",
    "goal_reached_fraction",
    "alert_time_s",
    "detection_delay_s",
    "false_alerts",
    "wall_clock_s",
    "gcs_compute_s",
    "gcs_update_p99_ms",
    "planner_decision_p99_ms",
)

_TOPICS = (
    topics.RUN_META,
    topics.RUN_END,
    topics.TRUTH,
    topics.ALERTS,
    topics.TRACKS,
    topics.REGIONS,
    topics.GCS_CYCLE,
    topics.DECISIONS,
)


# --------------------------------------------------------------------------------------------
# The log, as arrays


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
    ``cov_enu_m2`` (R, 3, 3), ``chi2`` (R,)."""

    t_s: FloatArray
    uas_id: NDArray[np.str_]
    center_enu_m: FloatArray
    cov_enu_m2: FloatArray
    chi2: FloatArray

    def __post_init__(self) -> None:
        _freeze(self.t_s, self.uas_id, self.center_enu_m, self.cov_enu_m2, self.chi2)

    def select(self, which: NDArray[Any]) -> Regions:
        """The records picked by a boolean mask or an index array."""
        return Regions(
            self.t_s[which],
            self.uas_id[which],
            self.center_enu_m[which],
            self.cov_enu_m2[which],
            self.chi2[which],
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
    )


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
    )


def _compute_ms(rows: list[tuple[float, dict[str, Any]]]) -> FloatArray:
    values = np.array([r.get("compute_ms") for _, r in rows], dtype=np.float64)
    return values[np.isfinite(values)]


# --------------------------------------------------------------------------------------------
# Building blocks


def count_entry_events(inside: BoolArray, separated: BoolArray) -> IntArray:
    """Entry events per column of (T, P) sample masks (see the module docstring).

    ``inside[k, p]``: sample k of pair p counts as a violation (inside and eligible);
    ``separated[k, p]``: the pair is apart at sample k (ends an episode). Returns (P,).
    """
    n_samples, n_pairs = inside.shape
    episode = np.cumsum(separated, axis=0)
    k, pair = np.nonzero(inside)
    keys = np.unique(pair.astype(np.int64) * (n_samples + 1) + episode[k, pair])
    return np.bincount(keys // (n_samples + 1), minlength=n_pairs).astype(np.int64)


def airborne(p_enu_m: FloatArray, armed: BoolArray, min_height_m: float) -> BoolArray:
    """(..., N) mask: armed and true height >= ``min_height_m`` (NaN height: not airborne)."""
    with np.errstate(invalid="ignore"):
        return armed & (p_enu_m[..., 2] >= min_height_m)


def _pair_events(
    p: FloatArray, flying: BoolArray, i: IntArray, j: IntArray, threshold_m: float
) -> int:
    """NMAC entry events summed over the pairs (i[k], j[k]) of truth columns."""
    total = 0
    for start in range(0, i.size, _PAIR_BLOCK):
        ii, jj = i[start : start + _PAIR_BLOCK], j[start : start + _PAIR_BLOCK]
        d = np.linalg.norm(p[:, ii] - p[:, jj], axis=-1)
        with np.errstate(invalid="ignore"):
            inside = (d < threshold_m) & flying[:, ii] & flying[:, jj]
            separated = d >= threshold_m
        total += int(count_entry_events(inside, separated).sum())
    return total


def _percentile(values: FloatArray, q: float) -> float | None:
    return float(np.percentile(values, q)) if values.size else None


def _or_none(value: float) -> float | None:
    return None if not math.isfinite(value) else float(value)


# --------------------------------------------------------------------------------------------
# The metrics


def _columns(truth: Truth, sysids: Sequence[int]) -> IntArray:
    cols = [truth.column(s) for s in sysids]
    return np.array([c for c in cols if c is not None], dtype=np.int64)


def alert_time_s(run: RunLog) -> float | None:
    if run.spoofer_serial is None:
        return None
    for t_s, alert in run.alerts:
        if str(alert.get("uas_id")) == run.spoofer_serial and alert.get("state") == "raised":
            return t_s
    return None


def detection_delay_s(run: RunLog) -> float | None:
    alert = alert_time_s(run)
    if alert is None or run.spoofer_heard_s is None:
        return None
    return alert - run.spoofer_heard_s


def false_alerts(run: RunLog) -> int:
    return sum(
        1
        for _t, alert in run.alerts
        if alert.get("state") == "raised" and str(alert.get("uas_id")) != run.spoofer_serial
    )


def _nmac(run: RunLog, min_height_m: float) -> tuple[int | None, int | None]:
    truth = run.truth
    benign = _columns(truth, run.benign_sysids)
    flying = airborne(truth.p_enu_m, truth.armed, min_height_m)
    i, j = np.triu_indices(benign.size, k=1)
    bb = _pair_events(truth.p_enu_m, flying, benign[i], benign[j], run.nmac_threshold_m)
    spoofer = None if run.spoofer_sysid is None else truth.column(run.spoofer_sysid)
    if spoofer is None:
        return bb, None
    others = np.full(benign.size, spoofer, dtype=np.int64)
    bs = _pair_events(truth.p_enu_m, flying, benign, others, run.nmac_threshold_m)
    return bb, bs


def _unsafe_violations(run: RunLog, min_height_m: float) -> int | None:
    regions = run.regions
    if regions.t_s.size == 0:
        return None
    benign = _columns(run.truth, run.benign_sysids)
    total = 0
    for uas_id in np.unique(regions.uas_id):
        group = regions.select(regions.uas_id == uas_id)
        order = np.argsort(group.t_s, kind="stable")
        group = group.select(order)
        p, armed = run.truth.at(group.t_s)
        p, armed = p[:, benign], armed[:, benign]
        m2 = mahalanobis2(p - group.center_enu_m[:, None, :], group.cov_enu_m2[:, None])
        chi2 = group.chi2[:, None]
        with np.errstate(invalid="ignore"):
            inside = (m2 <= chi2) & airborne(p, armed, min_height_m)
            separated = m2 > chi2
        total += int(count_entry_events(inside, separated).sum())
    return total


def _spoofer_regions_after_alert(run: RunLog) -> Regions | None:
    alert = alert_time_s(run)
    if alert is None:
        return None
    mask = (run.regions.uas_id == run.spoofer_serial) & (run.regions.t_s >= alert)
    return run.regions.select(mask)


def _containment(run: RunLog) -> tuple[FloatArray, BoolArray]:
    """(times, contained) of the spoofer's regions at/after the alert (empty if none)."""
    regions = _spoofer_regions_after_alert(run)
    column = None if run.spoofer_sysid is None else run.truth.column(run.spoofer_sysid)
    if regions is None or column is None or regions.t_s.size == 0:
        return np.zeros(0), np.zeros(0, dtype=bool)
    p, _armed = run.truth.at(regions.t_s)
    m2 = mahalanobis2(p[:, column] - regions.center_enu_m, regions.cov_enu_m2)
    with np.errstate(invalid="ignore"):
        contained = m2 <= regions.chi2
    known = np.isfinite(m2)
    return regions.t_s[known], contained[known]


def _localisation_errors(run: RunLog) -> tuple[FloatArray, FloatArray]:
    """(times, 3D errors) of the spoofer's track estimates at/after the alert."""
    alert = alert_time_s(run)
    column = None if run.spoofer_sysid is None else run.truth.column(run.spoofer_sysid)
    if alert is None or column is None:
        return np.zeros(0), np.zeros(0)
    mask = (run.track_uas_id == run.spoofer_serial) & (run.track_t_s >= alert)
    t = run.track_t_s[mask]
    p, _armed = run.truth.at(t)
    error = np.linalg.norm(run.track_p_enu_m[mask] - p[:, column], axis=-1)
    known = np.isfinite(error)
    return t[known], error[known]


def _max_radius(run: RunLog) -> float | None:
    if run.spoofer_serial is None:
        return None
    regions = run.regions.select(run.regions.uas_id == run.spoofer_serial)
    if regions.t_s.size == 0:
        return None
    largest = np.linalg.eigvalsh(regions.cov_enu_m2)[:, -1]
    return _or_none(float(np.nanmax(np.sqrt(regions.chi2 * np.clip(largest, 0.0, None)))))


def _distance_to_spoofer(run: RunLog, min_height_m: float) -> FloatArray:
    """(T,) min over airborne benign aircraft of the true distance to the spoofer (NaN:
    none airborne or no spoofer)."""
    truth = run.truth
    column = None if run.spoofer_sysid is None else truth.column(run.spoofer_sysid)
    if column is None:
        return np.full(truth.t_s.size, np.nan)
    benign = _columns(truth, run.benign_sysids)
    d = np.linalg.norm(truth.p_enu_m[:, benign] - truth.p_enu_m[:, column, None], axis=-1)
    flying = airborne(truth.p_enu_m[:, benign], truth.armed[:, benign], min_height_m)
    d = np.where(flying & np.isfinite(d), d, np.inf)
    closest = d.min(axis=1, initial=np.inf)
    return np.where(np.isfinite(closest), closest, np.nan)


def arrival_times_s(run: RunLog) -> dict[int, float | None]:
    """Benign sysid -> first truth time within the arrival radius (horizontal) of its goal."""
    truth = run.truth
    arrivals: dict[int, float | None] = {}
    for sysid in run.benign_sysids:
        column = truth.column(sysid)
        goal = run.goals_enu_m.get(sysid)
        if column is None or goal is None:
            arrivals[sysid] = None
            continue
        horizontal = np.hypot(
            truth.p_enu_m[:, column, 0] - goal[0], truth.p_enu_m[:, column, 1] - goal[1]
        )
        with np.errstate(invalid="ignore"):
            hits = np.flatnonzero(horizontal <= run.arrival_radius_m)
        arrivals[sysid] = float(truth.t_s[hits[0]]) if hits.size else None
    return arrivals


def _goal_fraction(run: RunLog) -> float | None:
    if not run.goals_enu_m or run.truth.t_s.size == 0:
        return None
    arrivals = arrival_times_s(run)
    reached = sum(1 for sysid in run.goals_enu_m if arrivals.get(sysid) is not None)
    return reached / len(run.goals_enu_m)


def compute_metrics(
    source: str | os.PathLike[str] | RunLog, *, min_height_m: float = DEFAULT_MIN_HEIGHT_M
) -> Metrics:
    """The run's metrics (keys :data:`METRIC_KEYS`; definitions in the module docstring)."""
    run = source if isinstance(source, RunLog) else load_run(source)
    nmac_bb, nmac_bs = _nmac(run, min_height_m) if run.truth.t_s.size else (None, None)
    _t, contained = _containment(run)
    _te, errors = _localisation_errors(run)
    distance = _distance_to_spoofer(run, min_height_m)
    end = run.end or {}
    wall = end.get("wall_clock_s")
    return {
        "nmac_benign_benign": nmac_bb,
        "nmac_benign_spoofer": nmac_bs,
        "unsafe_violations": _unsafe_violations(run, min_height_m),
        "containment_rate": float(contained.mean()) if contained.size else None,
        "rmse_m": float(np.sqrt(np.mean(errors**2))) if errors.size else None,
        "mae_m": float(np.mean(errors)) if errors.size else None,
        "max_ellipsoid_radius_m": _max_radius(run),
        "min_distance_to_spoofer_m": _or_none(float(np.nanmin(distance)))
        if np.isfinite(distance).any()
        else None,
        "goal_reached_fraction": _goal_fraction(run),
        "alert_time_s": alert_time_s(run),
        "detection_delay_s": detection_delay_s(run),
        "false_alerts": false_alerts(run),
        "wall_clock_s": None if wall is None else float(wall),
        "gcs_compute_s": float(run.gcs_compute_ms.sum() / 1000.0)
        if run.gcs_compute_ms.size
        else None,
        "gcs_update_p99_ms": _percentile(run.gcs_compute_ms, 99.0),
        "planner_decision_p99_ms": _percentile(run.decision_compute_ms, 99.0),
    }


# --------------------------------------------------------------------------------------------
# Time series (the paper's Fig. 3)


@dataclass(frozen=True, eq=False)
class MetricSeries:
    """Metrics over time, for plots.

    - ``t_s`` (T,), ``min_distance_to_spoofer_m`` (T,): truth samples; NaN where no benign
      aircraft is airborne or there is no spoofer.
    - ``region_t_s`` (K,), ``contained`` (K,), ``containment_rate`` (K,): each spoofer region
      at/after the alert, whether it contained the truth, and the running fraction so far.
    - ``track_t_s`` (M,), ``localisation_error_m`` (M,): 3D error of each spoofer track record
      at/after the alert.
    - ``arrival_time_s``: benign sysid -> first time within the arrival radius, or None.
    """

    t_s: FloatArray
    min_distance_to_spoofer_m: FloatArray
    region_t_s: FloatArray
    contained: BoolArray
    containment_rate: FloatArray
    track_t_s: FloatArray
    localisation_error_m: FloatArray
    alert_time_s: float | None
    nmac_threshold_m: float
    arrival_time_s: Mapping[int, float | None]


def metric_series(
    source: str | os.PathLike[str] | RunLog, *, min_height_m: float = DEFAULT_MIN_HEIGHT_M
) -> MetricSeries:
    run = source if isinstance(source, RunLog) else load_run(source)
    region_t, contained = _containment(run)
    running = np.cumsum(contained) / np.arange(1, contained.size + 1)
    track_t, errors = _localisation_errors(run)
    return MetricSeries(
        t_s=run.truth.t_s,
        min_distance_to_spoofer_m=_distance_to_spoofer(run, min_height_m),
        region_t_s=region_t,
        contained=contained,
        containment_rate=running.astype(np.float64),
        track_t_s=track_t,
        localisation_error_m=errors,
        alert_time_s=alert_time_s(run),
        nmac_threshold_m=run.nmac_threshold_m,
        arrival_time_s=arrival_times_s(run),
    )
