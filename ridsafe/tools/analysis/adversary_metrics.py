"""Metrics per adversary (every spoofer and ghost of ``/run/meta``'s ``adversaries``).

``compute_metrics`` merges :func:`adversary_metrics` into its result. For a run with one
spoofer and no ghost the common keys are those ``metrics`` already computes, the same values;
with several adversaries:

- ``nmac_benign_spoofer``: NMAC entry events of (benign, spoofer) pairs summed over every
  spoofer's true position (ghost transmitters are not aircraft: not counted);
- ``false_alerts``: ``raised`` alerts for a serial that is no adversary's (a ghost's alert is
  a true alert);
- ``containment_rate`` / ``rmse_m``: the mean over spoofers of each one's rate (its regions at
  or after its own first alert, containing its true position) and RMSE (its track), spoofers
  never alerted left out; ``containment_rate_min`` the worst one; ``spoofers_alerted`` how many
  of ``spoofer_count`` were.

Always (also with one spoofer; so a run with ghosts compares with the same seed without):
``benign_path_length_m`` (sum over benign aircraft of the 3D length flown, truth samples) and
``mean_arrival_time_s`` (over the aircraft that arrived). With ghosts: ``ghosts_alerted``
(ghosts with a raised alert) and ``ghost_region_containment`` (fraction of the ghosts'
regions that contain the ghost's real transmitter: the GCS knows where the radio is).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.ellipsoid import mahalanobis2
from ridsafe.tools.analysis.encounters import airborne, pair_entry_events
from ridsafe.tools.analysis.run_arrays import RunLog

FloatArray = NDArray[np.float64]
Metrics = dict[str, float | int | None]

__all__ = ["adversaries_of", "adversary_metrics", "per_adversary"]


def adversaries_of(run: RunLog) -> list[Mapping[str, Any]]:
    """``/run/meta``'s adversaries (empty for logs written before they were listed)."""
    items = run.meta.get("adversaries") or []
    return [a for a in items if isinstance(a, Mapping)]


def _alert_s(run: RunLog, serial: str) -> float | None:
    for t_s, alert in run.alerts:
        if str(alert.get("uas_id")) == serial and alert.get("state") == "raised":
            return t_s
    return None


def _containment(
    run: RunLog, serial: str, column: int, since_s: float, point: FloatArray | None = None
) -> float | None:
    """Fraction of ``serial``'s regions at/after ``since_s`` containing the truth of ``column``
    (or the fixed ``point``)."""
    regions = run.regions.select((run.regions.uas_id == serial) & (run.regions.t_s >= since_s))
    if regions.t_s.size == 0:
        return None
    if point is None:
        p, _armed = run.truth.at(regions.t_s)
        truth = p[:, column]
    else:
        truth = np.broadcast_to(point, regions.center_enu_m.shape)
    m2 = mahalanobis2(truth - regions.center_enu_m, regions.cov_enu_m2)
    known = np.isfinite(m2)
    if not known.any():
        return None
    return float(np.mean(m2[known] <= regions.chi2[known]))


def _rmse(run: RunLog, serial: str, column: int, since_s: float) -> float | None:
    mask = (run.track_uas_id == serial) & (run.track_t_s >= since_s)
    if not mask.any():
        return None
    p, _armed = run.truth.at(run.track_t_s[mask])
    error = np.linalg.norm(run.track_p_enu_m[mask] - p[:, column], axis=-1)
    error = error[np.isfinite(error)]
    return float(np.sqrt(np.mean(error**2))) if error.size else None


def per_adversary(run: RunLog, min_height_m: float) -> list[dict[str, Any]]:
    """One row per adversary: serial, role, alert time, containment, RMSE, NMACs (spoofers)."""
    truth = run.truth
    benign = np.array(
        [c for c in (truth.column(s) for s in run.benign_sysids) if c is not None], dtype=np.int64
    )
    flying = airborne(truth.p_enu_m, truth.armed, min_height_m)
    rows: list[dict[str, Any]] = []
    for adversary in adversaries_of(run):
        serial, role = str(adversary["serial"]), str(adversary.get("role"))
        column = truth.column(int(adversary["sysid"]))
        alert = _alert_s(run, serial)
        row: dict[str, Any] = {"serial": serial, "role": role, "alert_time_s": alert}
        if column is not None and role == "spoofer":
            others = np.full(benign.size, column, dtype=np.int64)
            row["nmac_benign"] = (
                pair_entry_events(truth.p_enu_m, flying, benign, others, run.nmac_threshold_m)
                if truth.t_s.size
                else 0
            )
            since = alert if alert is not None else np.inf
            row["containment_rate"] = _containment(run, serial, column, since)
            row["rmse_m"] = _rmse(run, serial, column, since)
        elif column is not None:
            transmitter = np.asarray(adversary.get("transmitter_enu_m"), dtype=np.float64)
            row["region_containment"] = _containment(run, serial, column, -np.inf, transmitter)
            row["region_count"] = int(np.count_nonzero(run.regions.uas_id == serial))
        rows.append(row)
    return rows


def _path_and_arrival(
    run: RunLog, arrivals_s: Mapping[int, float | None]
) -> tuple[float | None, float | None]:
    truth = run.truth
    columns = [c for c in (truth.column(s) for s in run.benign_sysids) if c is not None]
    if truth.t_s.size < 2 or not columns:
        return None, None
    steps = np.linalg.norm(np.diff(truth.p_enu_m[:, columns], axis=0), axis=-1)
    path = float(np.nansum(steps))
    arrivals = [t for t in arrivals_s.values() if t is not None]
    return path, (float(np.mean(arrivals)) if arrivals else None)


def _mean(values: list[float | None]) -> float | None:
    known = [v for v in values if v is not None]
    return float(np.mean(known)) if known else None


def adversary_metrics(
    run: RunLog, min_height_m: float, arrivals_s: Mapping[int, float | None]
) -> Metrics:
    """The keys of the module docstring (``arrivals_s``: ``metrics.arrival_times_s``)."""
    path, arrival = _path_and_arrival(run, arrivals_s)
    out: Metrics = {"benign_path_length_m": path, "mean_arrival_time_s": arrival}
    listed = adversaries_of(run)
    spoofers = [a for a in listed if a.get("role") == "spoofer"]
    ghosts = [a for a in listed if a.get("role") == "ghost"]
    if len(spoofers) <= 1 and not ghosts:
        return out
    rows = per_adversary(run, min_height_m)
    spoofer_rows = [r for r in rows if r["role"] == "spoofer"]
    ghost_rows = [r for r in rows if r["role"] == "ghost"]
    serials = {str(a["serial"]) for a in listed}
    containments = [r.get("containment_rate") for r in spoofer_rows]
    known = [c for c in containments if c is not None]
    out.update(
        {
            "nmac_benign_spoofer": sum(int(r.get("nmac_benign") or 0) for r in spoofer_rows),
            "false_alerts": sum(
                1
                for _t, alert in run.alerts
                if alert.get("state") == "raised" and str(alert.get("uas_id")) not in serials
            ),
            "spoofer_count": len(spoofer_rows),
            "spoofers_alerted": sum(1 for r in spoofer_rows if r["alert_time_s"] is not None),
            "containment_rate": _mean(containments),
            "containment_rate_min": min(known) if known else None,
            "rmse_m": _mean([r.get("rmse_m") for r in spoofer_rows]),
        }
    )
    if ghost_rows:
        out["ghosts_alerted"] = sum(1 for r in ghost_rows if r["alert_time_s"] is not None)
        out["ghost_region_containment"] = _mean([r.get("region_containment") for r in ghost_rows])
    return out
