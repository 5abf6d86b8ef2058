"""Metrics per adversary (every spoofer and ghost of ``/run/meta``'s ``adversaries``; the
bystanders listed there, honest aircraft outside the fleet, are no adversaries).

``compute_metrics`` merges :func:`adversary_metrics` into its result. For a run with one
spoofer, no ghost and no bystander the common keys are those ``metrics`` already computes, the
same values; with several adversaries or a bystander:

- ``nmac_benign_spoofer``: NMAC entry events of (benign, spoofer) pairs summed over every
  spoofer's true position (ghost transmitters are not aircraft: not counted; nor are
  bystanders, whose Remote ID tells every planner where they are);
- ``false_alerts``: ``raised`` alerts for a serial that is no adversary's (a ghost's alert is
  a true alert, a bystander's a false one); ``bystanders_alerted``: how many of
  ``bystander_count`` bystanders had one;
- ``containment_rate`` / ``rmse_m``: the mean over spoofers of each one's rate (its regions at
  or after its own first alert, containing its true position) and RMSE (its track), spoofers
  never alerted left out; ``containment_rate_min`` the worst one; ``spoofers_alerted`` how many
  of ``spoofer_count`` were.

When the lie can hurt: a planner that trusts Remote ID keeps ``d_safe_m`` (the planner's, 100 m)
from where the RID says an aircraft is; the true aircraft is ``|lie|`` from there, so the
trusting planner may come within ``d_safe_m - |lie|`` of it, an NMAC once that is under the
NMAC radius: the lie can hurt once ``|lie| > harm_lie_m = d_safe_m - nmac_threshold_m`` (50 m).
Per spoofer (truth channel: claimed vs true position): ``lie_at_alert_m``, ``harm_time_s`` (first
time the lie exceeds ``harm_lie_m``; None: never) and ``alerted_before_harm``; the run's
``spoofers_alerted_before_harm`` counts the spoofers whose lie never got there un-alerted;
``spoofer_regions_on_ground`` counts the spoofers' regions the GCS sent flagged ON_GROUND
(a spoofer taken for a radio on the ground: ``gcs/region/ground.py``).

Whenever the run lists adversaries (also one spoofer; so a run with ghosts compares with the
same seed without):
``benign_path_length_m`` (sum over benign aircraft of the 3D length flown, truth samples) and
``mean_arrival_time_s`` (over the aircraft that arrived). With ghosts: ``ghosts_alerted``
(ghosts with a raised alert), ``ghost_region_containment`` (fraction of the ghosts'
regions that contain the ghost's real transmitter: the GCS knows where the radio is),
``ghost_on_ground_fraction`` (fraction of their regions the GCS sent flagged ON_GROUND, a
radio on the ground: ``gcs/region/ground.py``) and ``ghost_on_ground_from_s`` (mean over the
ghosts so flagged of the first such region's time).

Pad holds (``/companion/events`` ``pad_blocked`` / ``pad_clear``, ``companion/pad_clearance.py``):
``pad_hold_s_ghosts``, ``pad_hold_s_other_regions``, ``pad_hold_s_aircraft``: aircraft-seconds
of take-off or landing held by a ghost's region, any other region, another aircraft (a hold
still on at the end counts to the end); ``aircraft_held_by_ghosts``: how many aircraft a
ghost's region ever held.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ridsafe.common import topics
from ridsafe.common.adversary import AdversaryRole
from ridsafe.common.ellipsoid import mahalanobis2
from ridsafe.common.messages import RegionFlags
from ridsafe.tools.analysis.encounters import airborne, pair_entry_events
from ridsafe.tools.analysis.run_arrays import RunLog
from ridsafe.tools.runlog.reader import read_records

FloatArray = NDArray[np.float64]
Metrics = dict[str, float | int | None]

__all__ = [
    "DEFAULT_D_SAFE_M",
    "adversaries_of",
    "adversary_metrics",
    "first_alert_s",
    "harm_lie_m",
    "pad_holds",
    "per_adversary",
]

#: The trusting planner's separation from a claimed position when the run does not say (m).
DEFAULT_D_SAFE_M = 100.0


def adversaries_of(run: RunLog) -> list[Mapping[str, Any]]:
    """``/run/meta``'s adversaries (empty for logs written before they were listed)."""
    items = run.meta.get("adversaries") or []
    return [a for a in items if isinstance(a, Mapping)]


def harm_lie_m(run: RunLog) -> float:
    """The lie beyond which a trusting planner could be steered into an NMAC (docstring)."""
    planner = (run.meta.get("scenario") or {}).get("planner") or {}
    d_safe = float(planner.get("d_safe_m", DEFAULT_D_SAFE_M))
    return max(d_safe - run.nmac_threshold_m, 0.0)


def _harm(
    t_s: FloatArray, lie_m: FloatArray, alert_s: float | None, limit_m: float
) -> dict[str, Any]:
    over = np.flatnonzero(lie_m > limit_m)
    harm = float(t_s[over[0]]) if over.size else None
    at_alert = None
    if alert_s is not None and t_s.size:
        at_alert = float(lie_m[max(int(np.searchsorted(t_s, alert_s, side="right")) - 1, 0)])
    before = harm is None or (alert_s is not None and alert_s <= harm)
    return {"lie_at_alert_m": at_alert, "harm_time_s": harm, "alerted_before_harm": before}


def first_alert_s(run: RunLog, serial: str) -> float | None:
    """When ``serial``'s first ``raised`` alert came (None: never)."""
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


def _on_ground_count(run: RunLog, serial: str) -> int:
    """How many of ``serial``'s regions the GCS sent flagged ON_GROUND."""
    mine = (run.regions.uas_id == serial) & ((run.regions.flags & int(RegionFlags.ON_GROUND)) != 0)
    return int(np.count_nonzero(mine))


def _rmse(run: RunLog, serial: str, column: int, since_s: float) -> float | None:
    mask = (run.track_uas_id == serial) & (run.track_t_s >= since_s)
    if not mask.any():
        return None
    p, _armed = run.truth.at(run.track_t_s[mask])
    error = np.linalg.norm(run.track_p_enu_m[mask] - p[:, column], axis=-1)
    error = error[np.isfinite(error)]
    return float(np.sqrt(np.mean(error**2))) if error.size else None


def per_adversary(run: RunLog, min_height_m: float) -> list[dict[str, Any]]:
    """One row per adversary: serial, role, alert time, containment, RMSE, NMACs (spoofers);
    per bystander its serial, role and alert time (a false alert) only."""
    truth = run.truth
    benign = np.array(
        [c for c in (truth.column(s) for s in run.benign_sysids) if c is not None], dtype=np.int64
    )
    flying = airborne(truth.p_enu_m, truth.armed, min_height_m)
    lies = run.spoofer_lies
    limit_m = harm_lie_m(run)
    rows: list[dict[str, Any]] = []
    for adversary in adversaries_of(run):
        serial, role = str(adversary["serial"]), str(adversary.get("role"))
        column = truth.column(int(adversary["sysid"]))
        alert = first_alert_s(run, serial)
        row: dict[str, Any] = {"serial": serial, "role": role, "alert_time_s": alert}
        if column is not None and role == AdversaryRole.SPOOFER:
            others = np.full(benign.size, column, dtype=np.int64)
            row["nmac_benign"] = (
                pair_entry_events(truth.p_enu_m, flying, benign, others, run.nmac_threshold_m)
                if truth.t_s.size
                else 0
            )
            since = alert if alert is not None else np.inf
            row["containment_rate"] = _containment(run, serial, column, since)
            row["rmse_m"] = _rmse(run, serial, column, since)
            row["regions_on_ground"] = _on_ground_count(run, serial)
            if serial in lies:
                row.update(_harm(*lies[serial], alert, limit_m))
        elif column is not None and role == AdversaryRole.GHOST:
            transmitter = np.asarray(adversary.get("transmitter_enu_m"), dtype=np.float64)
            row["region_containment"] = _containment(run, serial, column, -np.inf, transmitter)
            mine = run.regions.select(run.regions.uas_id == serial)
            row["region_count"] = int(mine.t_s.size)
            on_ground = (mine.flags & int(RegionFlags.ON_GROUND)) != 0
            row["on_ground_fraction"] = float(np.mean(on_ground)) if mine.t_s.size else None
            row["on_ground_from_s"] = float(mine.t_s[on_ground][0]) if on_ground.any() else None
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
    listed = adversaries_of(run)
    if not listed:  # no adversary (or a log from before they were listed): no extra key
        return {}
    path, arrival = _path_and_arrival(run, arrivals_s)
    out: Metrics = {"benign_path_length_m": path, "mean_arrival_time_s": arrival}
    spoofers = [a for a in listed if a.get("role") == AdversaryRole.SPOOFER]
    ghosts = [a for a in listed if a.get("role") == AdversaryRole.GHOST]
    bystanders = [a for a in listed if a.get("role") == AdversaryRole.BYSTANDER]
    rows = per_adversary(run, min_height_m)
    out["spoofers_alerted_before_harm"] = sum(
        1 for r in rows if r["role"] == AdversaryRole.SPOOFER and r.get("alerted_before_harm")
    )
    lies = [r.get("lie_at_alert_m") for r in rows if r["role"] == AdversaryRole.SPOOFER]
    out["lie_at_alert_m"] = _mean(lies)
    out["spoofer_regions_on_ground"] = sum(
        int(r.get("regions_on_ground") or 0) for r in rows if r["role"] == AdversaryRole.SPOOFER
    )
    if len(spoofers) <= 1 and not ghosts and not bystanders:
        return out
    spoofer_rows = [r for r in rows if r["role"] == AdversaryRole.SPOOFER]
    ghost_rows = [r for r in rows if r["role"] == AdversaryRole.GHOST]
    serials = {str(a["serial"]) for a in spoofers + ghosts}
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
    if bystanders:
        out["bystander_count"] = len(bystanders)
        out["bystanders_alerted"] = sum(
            1
            for r in rows
            if r["role"] == AdversaryRole.BYSTANDER and r["alert_time_s"] is not None
        )
    if ghost_rows:
        out["ghosts_alerted"] = sum(1 for r in ghost_rows if r["alert_time_s"] is not None)
        out["ghost_region_containment"] = _mean([r.get("region_containment") for r in ghost_rows])
        out["ghost_on_ground_fraction"] = _mean([r.get("on_ground_fraction") for r in ghost_rows])
        out["ghost_on_ground_from_s"] = _mean([r.get("on_ground_from_s") for r in ghost_rows])
    if run.path.exists():
        end_s = float(run.truth.t_s[-1]) if run.truth.t_s.size else 0.0
        roles = {str(a["serial"]): str(a.get("role")) for a in listed}
        out.update(pad_holds(run.path, end_s, roles))
    return out


def pad_holds(path: Path, end_s: float, roles: Mapping[str, str]) -> Metrics:
    """The pad-hold keys of the module docstring, from the companions' events in the log at
    ``path`` (``roles``: adversary serial -> "spoofer" / "ghost"; holds still on end at
    ``end_s``)."""
    held: dict[str, float] = {"ghost": 0.0, "region": 0.0, "aircraft": 0.0}
    by_ghost: set[int] = set()
    since: dict[int, tuple[float, str]] = {}  # sysid -> (held from, by which kind)

    def close(sysid: int, t_s: float) -> None:
        start = since.pop(sysid, None)
        if start is not None:
            held[start[1]] += t_s - start[0]

    for _topic, t_s, record in read_records(path, topics=(topics.COMPANION_EVENTS,)):
        event, sysid = record.get("event"), int(record.get("sysid", 0))
        if event not in ("pad_blocked", "pad_clear"):
            continue
        close(sysid, t_s)
        if event == "pad_blocked":
            what, _, who = str(record.get("detail", "")).rpartition(": ")[2].partition(" ")
            kind = "aircraft" if what == "aircraft" else "region"
            kind = "ghost" if kind == "region" and roles.get(who) == AdversaryRole.GHOST else kind
            since[sysid] = (t_s, kind)
            if kind == "ghost":
                by_ghost.add(sysid)
    for sysid in list(since):
        close(sysid, end_s)
    return {
        "pad_hold_s_ghosts": held["ghost"],
        "pad_hold_s_other_regions": held["region"],
        "pad_hold_s_aircraft": held["aircraft"],
        "aircraft_held_by_ghosts": len(by_ghost),
    }
