r"""Run metrics, computed from the run log (MCAP) alone (DESIGN.md section 7, paper Tables 2-3).

Inputs are the records of ``ridsafe.common.topics``: truth ``/truth/vehicles`` (10 Hz),
``/run/meta`` (benign aircraft and goals, spoofer, NMAC threshold), ``/gcs/alerts``,
``/gcs/tracks``, ``/gcs/unsafe_regions``, ``/gcs/cycle``, ``/companion/decisions``,
``/run/end``. "The spoofer" is ``/run/meta``'s ``spoofer`` (sysid for truth, serial for the
GCS records). A quantity that does not apply is ``None`` (no spoofer, no alert, no region...).

Airborne aircraft and entry events (every NMAC variant and ``unsafe_violations`` counts
events, not samples) are defined in :mod:`ridsafe.tools.analysis.encounters`; how the log
becomes arrays (truth interpolation) in :mod:`ridsafe.tools.analysis.run_arrays`.

- ``nmac_benign_benign``: entry events over all benign pairs, 3D true distance, threshold
  ``nmac_threshold_m`` from ``/run/meta`` (50 m).
- ``nmac_benign_spoofer``: the same for (benign, true spoofer) pairs. None without spoofer.
- ``unsafe_violations``: for every ``/gcs/unsafe_regions`` record (one per GCS update and
  region), each benign aircraft's true position ``x`` at the record time is inside when
  ``(x - c)^T P^-1 (x - c) <= chi2_threshold``; entry events per (aircraft, region uas_id)
  over that region's updates (the first update finding an aircraft inside is an entry).
  A benign aircraft is never counted inside the region raised about its own serial (a
  false alert): it cannot leave itself. None when the log has no region at all (trust-RID
  publishes none).
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
- ``landed_fraction``: fraction of those aircraft that also touched down on their sites
  after arriving: a truth sample not airborne (disarmed, or below the airborne height) and
  horizontally within the arrival radius of the goal, at or after the arrival, before the
  run ended (an aircraft down beside its site has not delivered). A descent from cruise
  height takes 40-60 s, so in a short run it counts the deliveries finished, where
  ``goal_reached_fraction`` counts those begun.
- ``alert_time_s``: time of the first ``raised`` alert for the spoofer's serial.
- ``detection_delay_s``: ``alert_time_s`` minus the time the spoofer's broadcasts had been
  heard by ``DETECTION_RECEIVERS`` (4) distinct aircraft (``/radio/receptions``, any RID
  message type): how long the GCS needed once it could in principle localise. Negative when
  it alerted earlier; None without alert or without such receptions.
- ``region_delay_s``: the spoofer's first unsafe region at or after ``alert_time_s`` minus
  ``alert_time_s``: how long the planners were told "a liar" before being told where it is.
  Alerted but no region before the truth ends: the truth's end minus the alert (a lower
  bound: the track never started). None without alert.
- ``false_alerts``: ``raised`` alerts for any uas_id but the spoofer's serial.
- ``false_alerts_per_aircraft_hour``: ``false_alerts`` over the benign aircraft's flight
  time (number of benign aircraft times the truth's time span, in hours); None without
  benign aircraft or truth.
- ``autopilot_failsafes``: companion-loss failsafes the sim's autopilots took
  (``/sim/events``); 0 in a healthy run.
- ``wall_clock_s``: ``/run/end``'s wall clock; None when the run has no end record.
- ``gcs_compute_s``: sum of ``/gcs/cycle`` ``compute_ms`` / 1000; ``gcs_update_p99_ms``
  and ``planner_decision_p99_ms`` (``/companion/decisions``): 99th percentile of
  ``compute_ms``, linear interpolation between order statistics (numpy's default, type 7).

:func:`ridsafe.tools.analysis.series.metric_series` gives the same quantities over time
(the paper's Fig. 3).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.ellipsoid import mahalanobis2
from ridsafe.tools.analysis.adversary_metrics import adversary_metrics, first_alert_s
from ridsafe.tools.analysis.encounters import airborne, count_entry_events, pair_entry_events
from ridsafe.tools.analysis.paper_metrics import PAPER_METRIC_KEYS, paper_metrics
from ridsafe.tools.analysis.run_arrays import Regions, RunLog, Truth, benign_serials, load_run

__all__ = [
    "DEFAULT_MIN_HEIGHT_M",
    "METRIC_KEYS",
    "Metrics",
    "alert_time_s",
    "arrival_times_s",
    "compute_metrics",
    "containment_samples",
    "distance_to_spoofer_m",
    "landing_times_s",
    "localisation_errors",
    "mahalanobis2",
]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
IntArray = NDArray[np.int64]
Metrics = dict[str, float | int | None]

DEFAULT_MIN_HEIGHT_M = 1.0

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
    "landed_fraction",
    "alert_time_s",
    "detection_delay_s",
    "region_delay_s",
    "false_alerts",
    "false_alerts_per_aircraft_hour",
    "wall_clock_s",
    "gcs_compute_s",
    "gcs_update_p99_ms",
    "planner_decision_p99_ms",
    "autopilot_failsafes",
    *PAPER_METRIC_KEYS,  # the paper's own definitions: analysis/paper_metrics.py
)


# --------------------------------------------------------------------------------------------
# Building blocks


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
    return None if run.spoofer_serial is None else first_alert_s(run, run.spoofer_serial)


def detection_delay_s(run: RunLog) -> float | None:
    alert = alert_time_s(run)
    if alert is None or run.spoofer_heard_s is None:
        return None
    return alert - run.spoofer_heard_s


def region_delay_s(run: RunLog) -> float | None:
    alert = alert_time_s(run)
    if alert is None:
        return None
    after = run.regions.t_s[(run.regions.uas_id == run.spoofer_serial) & (run.regions.t_s >= alert)]
    if after.size:
        return float(after.min()) - alert
    return float(run.truth.t_s[-1]) - alert if run.truth.t_s.size else None


def false_alerts(run: RunLog) -> int:
    return sum(
        1
        for _t, alert in run.alerts
        if alert.get("state") == "raised" and str(alert.get("uas_id")) != run.spoofer_serial
    )


def false_alerts_per_aircraft_hour(run: RunLog) -> float | None:
    span_s = float(run.truth.t_s[-1] - run.truth.t_s[0]) if run.truth.t_s.size > 1 else 0.0
    hours = len(run.benign_sysids) * span_s / 3600.0
    return false_alerts(run) / hours if hours > 0.0 else None


def _nmac(run: RunLog, min_height_m: float) -> tuple[int | None, int | None]:
    truth = run.truth
    benign = _columns(truth, run.benign_sysids)
    flying = airborne(truth.p_enu_m, truth.armed, min_height_m)
    i, j = np.triu_indices(benign.size, k=1)
    bb = pair_entry_events(truth.p_enu_m, flying, benign[i], benign[j], run.nmac_threshold_m)
    spoofer = None if run.spoofer_sysid is None else truth.column(run.spoofer_sysid)
    if spoofer is None:
        return bb, None
    others = np.full(benign.size, spoofer, dtype=np.int64)
    bs = pair_entry_events(truth.p_enu_m, flying, benign, others, run.nmac_threshold_m)
    return bb, bs


def _unsafe_violations(run: RunLog, min_height_m: float) -> int | None:
    regions = run.regions
    if regions.t_s.size == 0:
        return None
    serials = benign_serials(run.meta)
    total = 0
    for uas_id in np.unique(regions.uas_id):
        own = serials.get(str(uas_id))
        benign = _columns(run.truth, [s for s in run.benign_sysids if s != own])
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


def containment_samples(run: RunLog) -> tuple[FloatArray, BoolArray]:
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


def localisation_errors(run: RunLog) -> tuple[FloatArray, FloatArray]:
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


def distance_to_spoofer_m(run: RunLog, min_height_m: float) -> FloatArray:
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


def landing_times_s(
    run: RunLog, arrivals: dict[int, float | None], flying: BoolArray
) -> dict[int, float | None]:
    """Benign sysid -> its first truth time on the ground (``flying`` False) on its site
    (horizontally within the arrival radius of its goal) at or after its arrival
    (``arrivals``, :func:`arrival_times_s`); None: not arrived, still airborne, or down
    beside its site."""
    truth = run.truth
    landings: dict[int, float | None] = {}
    for sysid, arrived in arrivals.items():
        column = truth.column(sysid)
        goal = run.goals_enu_m.get(sysid)
        if arrived is None or column is None or goal is None:
            landings[sysid] = None
            continue
        first = int(np.searchsorted(truth.t_s, arrived))
        p = truth.p_enu_m[first:, column]
        with np.errstate(invalid="ignore"):
            on_site = np.hypot(p[:, 0] - goal[0], p[:, 1] - goal[1]) <= run.arrival_radius_m
        down = np.flatnonzero(~flying[first:, column] & on_site)
        landings[sysid] = float(truth.t_s[first + int(down[0])]) if down.size else None
    return landings


def _goal_fractions(
    run: RunLog, arrivals: dict[int, float | None], min_height_m: float
) -> tuple[float | None, float | None]:
    """``goal_reached_fraction`` and ``landed_fraction`` (``arrivals``: :func:`arrival_times_s`)."""
    if not run.goals_enu_m or run.truth.t_s.size == 0:
        return None, None
    flying = airborne(run.truth.p_enu_m, run.truth.armed, min_height_m)
    landings = landing_times_s(run, arrivals, flying)
    reached = sum(1 for sysid in run.goals_enu_m if arrivals.get(sysid) is not None)
    landed = sum(1 for sysid in run.goals_enu_m if landings.get(sysid) is not None)
    return reached / len(run.goals_enu_m), landed / len(run.goals_enu_m)


def compute_metrics(
    source: str | os.PathLike[str] | RunLog, *, min_height_m: float = DEFAULT_MIN_HEIGHT_M
) -> Metrics:
    """The run's metrics (keys :data:`METRIC_KEYS`; definitions in the module docstring)."""
    run = source if isinstance(source, RunLog) else load_run(source)
    nmac_bb, nmac_bs = _nmac(run, min_height_m) if run.truth.t_s.size else (None, None)
    _t, contained = containment_samples(run)
    _te, errors = localisation_errors(run)
    distance = distance_to_spoofer_m(run, min_height_m)
    arrivals = arrival_times_s(run)
    goal_reached, landed = _goal_fractions(run, arrivals, min_height_m)
    end = run.end or {}
    wall = end.get("wall_clock_s")
    metrics: Metrics = {
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
        "goal_reached_fraction": goal_reached,
        "landed_fraction": landed,
        "alert_time_s": alert_time_s(run),
        "detection_delay_s": detection_delay_s(run),
        "region_delay_s": region_delay_s(run),
        "false_alerts": false_alerts(run),
        "false_alerts_per_aircraft_hour": false_alerts_per_aircraft_hour(run),
        "wall_clock_s": None if wall is None else float(wall),
        "gcs_compute_s": float(run.gcs_compute_ms.sum() / 1000.0)
        if run.gcs_compute_ms.size
        else None,
        "gcs_update_p99_ms": _percentile(run.gcs_compute_ms, 99.0),
        "planner_decision_p99_ms": _percentile(run.decision_compute_ms, 99.0),
        "autopilot_failsafes": run.autopilot_failsafes,
        **paper_metrics(run, min_height_m),
    }
    metrics.update(adversary_metrics(run, min_height_m, arrivals))  # several spoofers, ghosts
    return metrics
