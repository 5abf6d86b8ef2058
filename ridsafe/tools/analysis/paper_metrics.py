r"""The paper's Table 2 metrics in the authors' own definitions, beside ours.

The authors' code (docs/paper_mode.md, "Metrics") counts and averages on the GCS's 0.25 s
ticks, not on our 10 Hz truth, and differs from :mod:`ridsafe.tools.analysis.metrics` in
four ways that move the numbers. These keys (prefix ``paper_``) follow their definitions so
that a paper-mode run can be set against the published table like for like:

- Ticks: ``t_k = k * PAPER_TICK_S`` for k = 1 .. floor(t_end / PAPER_TICK_S), t_end the last
  truth sample; truth interpolated at ``t_k``. The region at a tick is the latest
  ``/gcs/unsafe_regions`` record at or before it, of any uas_id, while its ``t_s`` is within
  ``PAPER_TICK_S`` (the GCS publishes one per cycle).
- Arrived aircraft: a benign aircraft that has come within ``ARRIVED_WITHIN_M`` (10 m) of
  its goal is excluded from every count from that tick on (latched). Theirs measure 3D to an
  airborne goal; our goals are on the ground and aircraft arrive above them, so horizontally.
  Ours keep counting any airborne aircraft. Airborne (armed, z >= ``min_height_m``) still
  applies: their aircraft
  were all airborne from t = 0, ours take off.
- ``paper_nmac_benign_benign`` / ``paper_nmac_benign_spoofer``: entry events (a pair within
  50 m at a tick and not at the previous one) over the ticks, both aircraft counted.
- ``paper_unsafe_violations``: per benign aircraft (not per aircraft and region), entry into
  *any* region published at the tick.
- ``paper_containment_rate``: over the ticks from the first spoofer region on that have one,
  the fraction whose ellipsoid holds the true spoofer.
- ``paper_rmse_m`` / ``paper_mae_m``: over the same ticks, ``e = |c - p_true|`` with ``c``
  the *published region's centre* (ours: the track estimate), RMSE = sqrt(mean e^2).
- ``paper_mean_ellipsoid_radius_m`` (the paper's "maximum unsafe-ellipsoid radius"): the
  largest semi-axis ``sqrt(chi2 lambda_max(P))`` of the spoofer's region at each tick, **0 at
  ticks without one** (before the alert), averaged over *all* ticks of the run. Ours
  (``max_ellipsoid_radius_m``) is the maximum over the run.
- ``paper_mean_horizontal_radius_m`` (not in the paper; a diagnostic of the one above): the
  same time mean of the largest semi-axis of the region's horizontal extent, ``sqrt(chi2
  lambda_max(P_xy))`` with ``P_xy`` the east-north block. The two differ when the vertical axis
  is the region's longest (docs/paper_mode.md, "Radius").
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.ellipsoid import mahalanobis2
from ridsafe.tools.analysis.encounters import airborne, count_entries
from ridsafe.tools.analysis.run_arrays import Regions, RunLog

__all__ = ["ARRIVED_WITHIN_M", "PAPER_METRIC_KEYS", "PAPER_TICK_S", "paper_metrics"]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
IntArray = NDArray[np.int64]

#: The authors' GCS tick (s).
PAPER_TICK_S = 0.25
#: A benign aircraft this close to its goal (3D, m) is done: excluded from then on.
ARRIVED_WITHIN_M = 10.0

PAPER_METRIC_KEYS: tuple[str, ...] = (
    "paper_nmac_benign_benign",
    "paper_nmac_benign_spoofer",
    "paper_unsafe_violations",
    "paper_containment_rate",
    "paper_rmse_m",
    "paper_mae_m",
    "paper_mean_ellipsoid_radius_m",
    "paper_mean_horizontal_radius_m",
)


def _ticks(run: RunLog) -> FloatArray:
    if run.truth.t_s.size == 0:
        return np.zeros(0)
    n = int(np.floor(float(run.truth.t_s[-1]) / PAPER_TICK_S + 1e-9))
    return PAPER_TICK_S * np.arange(1, n + 1, dtype=np.float64)


def _region_index(regions: Regions, ticks: FloatArray) -> IntArray:
    """(T,) index into ``regions`` (sorted by time) of the latest record at or before each
    tick and fresh (within one tick), else -1."""
    if regions.t_s.size == 0:
        return np.full(ticks.size, -1, dtype=np.int64)
    k = np.searchsorted(regions.t_s, ticks + 1e-9, side="right") - 1
    fresh = (k >= 0) & (ticks - regions.t_s[np.maximum(k, 0)] < PAPER_TICK_S - 1e-9)
    return np.where(fresh, k, -1)


def _active_benign(
    run: RunLog, sysids: list[int], p: FloatArray, armed: BoolArray, min_height_m: float
) -> BoolArray:
    """(T, B) benign aircraft (``sysids``, the columns of ``p``) counted at each tick: airborne
    and not yet arrived (latched)."""
    active = airborne(p, armed, min_height_m)
    for b, sysid in enumerate(sysids):
        goal = run.goals_enu_m.get(sysid)
        if goal is None:
            continue
        with np.errstate(invalid="ignore"):
            near = np.linalg.norm(p[:, b, :2] - np.asarray(goal)[:2], axis=-1) <= ARRIVED_WITHIN_M
        active[:, b] &= ~np.logical_or.accumulate(near)
    return active


def _nmac(p: FloatArray, active: BoolArray, p_spoofer: FloatArray | None) -> tuple[int, int | None]:
    i, j = np.triu_indices(p.shape[1], k=1)
    with np.errstate(invalid="ignore"):
        d = np.linalg.norm(p[:, i] - p[:, j], axis=-1)
        bb = count_entries((d < 50.0) & active[:, i] & active[:, j])
        if p_spoofer is None:
            return bb, None
        ds = np.linalg.norm(p - p_spoofer[:, None, :], axis=-1)
        return bb, count_entries((ds < 50.0) & active)


def _inside_any(regions: Regions, at: FloatArray, p: FloatArray) -> BoolArray:
    """(T, B): benign position inside any region published at the tick (time ``at``)."""
    inside = np.zeros(p.shape[:2], dtype=bool)
    for uas_id in np.unique(regions.uas_id):
        group = regions.select(regions.uas_id == uas_id)
        k = _region_index(group, at)
        has = k >= 0
        if not has.any():
            continue
        kk = k[has]
        m2 = mahalanobis2(
            p[has] - group.center_enu_m[kk][:, None, :], group.cov_enu_m2[kk][:, None]
        )
        with np.errstate(invalid="ignore"):
            inside[has] |= m2 <= group.chi2[kk][:, None]
    return inside


def _spoofer_region_stats(
    run: RunLog, ticks: FloatArray, p_spoofer: FloatArray | None
) -> dict[str, float | None]:
    out: dict[str, float | None] = dict.fromkeys(PAPER_METRIC_KEYS[3:])
    if run.spoofer_serial is None or ticks.size == 0:
        return out
    group = run.regions.select(run.regions.uas_id == run.spoofer_serial)
    k = _region_index(group, ticks)
    has = k >= 0
    radius, horizontal = np.zeros(ticks.size), np.zeros(ticks.size)
    if has.any():
        cov = group.cov_enu_m2[k[has]]
        largest = np.clip(np.linalg.eigvalsh(cov)[:, -1], 0.0, None)
        largest_xy = np.clip(np.linalg.eigvalsh(cov[:, :2, :2])[:, -1], 0.0, None)
        radius[has] = np.sqrt(group.chi2[k[has]] * largest)
        horizontal[has] = np.sqrt(group.chi2[k[has]] * largest_xy)
    out["paper_mean_ellipsoid_radius_m"] = float(radius.mean())
    out["paper_mean_horizontal_radius_m"] = float(horizontal.mean())
    if p_spoofer is None or not has.any():
        return out
    kk = k[has]
    truth = p_spoofer[has]
    error = np.linalg.norm(group.center_enu_m[kk] - truth, axis=-1)
    m2 = mahalanobis2(truth - group.center_enu_m[kk], group.cov_enu_m2[kk])
    known = np.isfinite(error)
    if known.any():
        out["paper_rmse_m"] = float(np.sqrt(np.mean(error[known] ** 2)))
        out["paper_mae_m"] = float(np.mean(error[known]))
        out["paper_containment_rate"] = float(np.mean(m2[known] <= group.chi2[kk][known]))
    return out


def paper_metrics(run: RunLog, min_height_m: float) -> dict[str, float | int | None]:
    """The ``paper_`` metrics of one run (definitions in the module docstring)."""
    ticks = _ticks(run)
    out: dict[str, float | int | None] = dict.fromkeys(PAPER_METRIC_KEYS)
    if ticks.size == 0:
        return out
    p_all, armed_all = run.truth.at(ticks)
    known = [(s, run.truth.column(s)) for s in run.benign_sysids]
    sysids = [s for s, c in known if c is not None]
    benign = np.array([c for _s, c in known if c is not None], dtype=np.int64)
    p, armed = p_all[:, benign], armed_all[:, benign]
    spoofer = None if run.spoofer_sysid is None else run.truth.column(run.spoofer_sysid)
    p_spoofer = None if spoofer is None else p_all[:, spoofer]
    active = _active_benign(run, sysids, p, armed, min_height_m)
    bb, bs = _nmac(p, active, p_spoofer)
    out["paper_nmac_benign_benign"], out["paper_nmac_benign_spoofer"] = bb, bs
    if run.regions.t_s.size:
        inside = _inside_any(run.regions, ticks, p) & active
        out["paper_unsafe_violations"] = count_entries(inside)
    out.update(_spoofer_region_stats(run, ticks, p_spoofer))
    return out
