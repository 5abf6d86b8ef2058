"""Where a run's benign-spoofer NMACs happen: one row per NMAC event, from the log alone.

The events are those ``nmac_benign_spoofer`` counts (``analysis.encounters``: a run of
samples closer than the NMAC radius with both airborne, between two samples apart), for every
spoofer of ``/run/meta``'s ``adversaries`` (or its one ``spoofer``). Per event, at its closest
sample:

- ``distance_m``: the true 3D distance; ``height_m``: the benign aircraft's true height (ENU z);
- ``phase``: the benign's mission phase then (the ``to`` of its companion's last ``phase``
  event, ``/companion/events``) and ``stage``, the phase's part of a flight (:class:`Stage`);
- ``from_pad_m`` / ``from_goal_m``: the benign's horizontal distance from its start and goal;
- ``alert_lag_s``: time since the spoofer's first raised alert (negative: the NMAC came before
  the alert; None: never alerted);
- ``in_region``: whether the spoofer's true position lay inside the last unsafe region the GCS
  had sent for it no more than :data:`REGION_STALE_S` before (None: no such region);
- ``planner_status``: the status of the benign's last planner decision then
  (``/companion/decisions``: ``cruise``, ``avoiding``, ``no_safe_action`` when no action kept
  clear of every region, ``arrived``, ``stuck``; None: no decision yet).

``ridsafe report`` lists them for the aware planner's runs (``analysis.adversary_report``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.adversary import AdversaryRole
from ridsafe.common.ellipsoid import mahalanobis2
from ridsafe.tools.analysis.adversary_metrics import adversaries_of, first_alert_s
from ridsafe.tools.analysis.encounters import airborne, entry_event_samples, pair_masks
from ridsafe.tools.analysis.flight_histories import Stage, flight_histories, stage_of, value_at
from ridsafe.tools.analysis.metrics import DEFAULT_MIN_HEIGHT_M
from ridsafe.tools.analysis.run_arrays import RunLog

__all__ = ["REGION_STALE_S", "SpooferNmac", "spoofer_nmacs"]

FloatArray = NDArray[np.float64]

#: A region older than this at the NMAC (s) says nothing about it (the GCS sends every 0.25 s).
REGION_STALE_S = 1.0


@dataclass(frozen=True)
class SpooferNmac:
    """One benign-spoofer NMAC event (fields: the module docstring)."""

    t_s: float
    benign_sysid: int
    spoofer_serial: str
    distance_m: float
    height_m: float
    phase: str | None
    stage: Stage
    from_pad_m: float | None
    from_goal_m: float | None
    alert_lag_s: float | None
    in_region: bool | None
    planner_status: str | None = None


def _spoofers(run: RunLog) -> list[tuple[int, str]]:
    """(sysid, serial) of every spoofer the run lists."""
    listed = [
        (int(a["sysid"]), str(a["serial"]))
        for a in adversaries_of(run)
        if a.get("role") == AdversaryRole.SPOOFER
    ]
    if listed or run.spoofer_sysid is None:
        return listed
    return [(run.spoofer_sysid, str(run.spoofer_serial))]


def _in_region(run: RunLog, serial: str, t_s: float, truth_enu_m: FloatArray) -> bool | None:
    regions = run.regions.select(
        (run.regions.uas_id == serial)
        & (run.regions.t_s <= t_s)
        & (run.regions.t_s >= t_s - REGION_STALE_S)
    )
    if regions.t_s.size == 0:
        return None
    last = int(np.argmax(regions.t_s))
    m2 = mahalanobis2(
        truth_enu_m[None, :] - regions.center_enu_m[last : last + 1],
        regions.cov_enu_m2[last : last + 1],
    )
    return bool(np.isfinite(m2[0]) and m2[0] <= regions.chi2[last])


def _horizontal_m(p_enu_m: FloatArray, other: object) -> float | None:
    if not isinstance(other, list | tuple) or len(other) < 2:
        return None
    return float(np.hypot(p_enu_m[0] - float(other[0]), p_enu_m[1] - float(other[1])))


def spoofer_nmacs(run: RunLog, min_height_m: float = DEFAULT_MIN_HEIGHT_M) -> list[SpooferNmac]:
    """Every benign-spoofer NMAC event of ``run``, in time order (``min_height_m``: airborne
    height, as the metrics use)."""
    truth = run.truth
    if truth.t_s.size == 0:
        return []
    flying = airborne(truth.p_enu_m, truth.armed, min_height_m)
    aircraft = {int(a["sysid"]): a for a in run.meta.get("aircraft") or [] if "sysid" in a}
    # (benign sysid, its column, spoofer serial, its column, closest sample, alert time)
    found: list[tuple[int, int, str, int, int, float | None]] = []
    events: list[SpooferNmac] = []
    for spoofer_sysid, serial in _spoofers(run):
        s = truth.column(spoofer_sysid)
        if s is None:
            continue
        alert_s = first_alert_s(run, serial)
        for sysid in run.benign_sysids:
            b = truth.column(sysid)
            if b is None:
                continue
            pair_b, pair_s = np.array([b]), np.array([s])
            d, inside, separated = pair_masks(
                truth.p_enu_m, flying, pair_b, pair_s, run.nmac_threshold_m
            )
            for samples in entry_event_samples(inside[:, 0], separated[:, 0]):
                k = int(samples[np.argmin(d[samples, 0])])
                found.append((sysid, b, serial, s, k, alert_s))
    phases, statuses = flight_histories(run, {sysid for sysid, *_ in found})
    for sysid, b, serial, s, k, alert_s in found:
        t_s, p = float(truth.t_s[k]), truth.p_enu_m[k, b]
        phase = value_at(phases.get(sysid, []), t_s)
        meta = aircraft.get(sysid, {})
        events.append(
            SpooferNmac(
                t_s=t_s,
                benign_sysid=sysid,
                spoofer_serial=serial,
                distance_m=float(np.linalg.norm(p - truth.p_enu_m[k, s])),
                height_m=float(p[2]),
                phase=phase,
                stage=stage_of(phase),
                from_pad_m=_horizontal_m(p, meta.get("start_enu_m")),
                from_goal_m=_horizontal_m(p, meta.get("goal_enu_m")),
                alert_lag_s=None if alert_s is None else t_s - alert_s,
                in_region=_in_region(run, serial, t_s, truth.p_enu_m[k, s]),
                planner_status=value_at(statuses.get(sysid, []), t_s),
            )
        )
    return sorted(events, key=lambda e: (e.t_s, e.benign_sysid, e.spoofer_serial))
