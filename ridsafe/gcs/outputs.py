r"""What the GCS sends and logs of a cycle's output: pure conversions, no state.

Regions go out in the companions' frames: centre ENU -> WGS-84 (``frames.enu_to_geodetic``),
velocity and covariance ENU -> NED with the permutation

    T = [[0, 1, 0], [1, 0, 0], [0, 0, -1]],   v_ned = T v_enu,   P_ned = T P_enu T^T

sent as the upper triangle (xx, xy, xz, yy, yz, zz). The records are those of ``topics.py``:
``/gcs/detector_stats`` (every detector's verdict on one claim), ``/gcs/alerts``,
``/gcs/tracks``, ``/gcs/unsafe_regions``.
"""

from __future__ import annotations

import math

import numpy as np

from ridsafe.common import frames
from ridsafe.common import messages as m
from ridsafe.common.frames import GeodeticOrigin
from ridsafe.gcs.pipeline_api import (
    AlertChange,
    DetectorResult,
    FloatArray,
    TrackEstimate,
    UnsafeRegion,
)

_UPPER = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))
#: How a detector is named in the log (10,000 detector records in a 120 s, 16-aircraft run).
_DETECTOR_NAMES = {d: d.name.lower() for d in m.RidsafeDetector}

Cov6 = tuple[float, float, float, float, float, float]


def ned_upper_triangle(cov_enu_m2: FloatArray) -> Cov6:
    """(3, 3) ENU covariance -> NED upper triangle (xx, xy, xz, yy, yz, zz): T P T^T."""
    p = frames.cov_enu_to_ned(cov_enu_m2)
    xx, xy, xz, yy, yz, zz = (float(p[i, j]) for i, j in _UPPER)
    return (xx, xy, xz, yy, yz, zz)


def region_message(
    origin: GeodeticOrigin, region: UnsafeRegion, now_s: float, validity_s: float, flags: int
) -> m.UnsafeRegionMsg:
    """The wire form of one unsafe region (see the module docstring); ``flags``:
    ``RegionFlags``."""
    east, north, up = (float(c) for c in region.center_enu_m)
    lat, lon, alt = frames.enu_to_geodetic_point(origin, east, north, up)
    v = frames.enu_to_ned(region.v_enu_m_s)
    return m.UnsafeRegionMsg(
        t_s=region.t_s,
        valid_until_s=min(region.valid_until_s, now_s + validity_s),
        center_lat_deg=lat,
        center_lon_deg=lon,
        center_alt_m=alt,
        cov_ned_m2=ned_upper_triangle(region.cov_enu_m2),
        v_ned_m_s=(float(v[0]), float(v[1]), float(v[2])),
        chi2_threshold=region.chi2_threshold,
        alpha=region.alpha,
        track_id=region.track_id,
        flags=flags,
        uas_id=region.uas_id,
    )


def region_is_finite(region: UnsafeRegion) -> bool:
    arrays = (region.center_enu_m, region.cov_enu_m2, region.v_enu_m_s)
    scalars = (region.chi2_threshold, region.alpha, region.valid_until_s, region.t_s)
    return all(bool(np.isfinite(a).all()) for a in arrays) and all(map(math.isfinite, scalars))


# --- records ---------------------------------------------------------------------------------


def alert_message(t_s: float, change: AlertChange) -> m.SpoofAlert:
    return m.SpoofAlert(
        t_s=t_s,
        statistic=float(change.statistic),
        threshold=float(change.threshold),
        detector=int(change.detector),
        state=int(change.state),
        uas_id=change.uas_id,
    )


def verdicts_record(results: tuple[DetectorResult, ...]) -> dict[str, object]:
    """The ``/gcs/detector_stats`` record of one claim: every detector's verdict on it."""
    verdicts = {
        _DETECTOR_NAMES[r.detector]: {
            "statistic": float(r.statistic),
            "threshold": float(r.threshold),
            "decision": bool(r.decision),
        }
        for r in results
    }
    return {"uas_id": results[0].uas_id, "detectors": verdicts}


def alert_record(change: AlertChange) -> dict[str, object]:
    return {
        "uas_id": change.uas_id,
        "detector": _DETECTOR_NAMES[change.detector],
        "statistic": float(change.statistic),
        "threshold": float(change.threshold),
        "state": change.state.name.lower(),
    }


def _listed(values: object) -> object:
    """An array-like of numbers as nested lists of Python floats (a record's JSON form)."""
    return np.asarray(values, dtype=np.float64).tolist()


def track_record(track: TrackEstimate) -> dict[str, object]:
    return {
        "uas_id": track.uas_id,
        "track_id": track.track_id,
        "p_enu_m": _listed(track.p_enu_m),
        "cov_enu_m2": _listed(track.cov_enu_m2),
        "v_enu_m_s": _listed(track.v_enu_m_s),
        "mode_probabilities": _listed(track.mode_probabilities),
        "fix": bool(track.fix),
        "last_fix_s": float(track.last_fix_s),
    }


def region_record(region: UnsafeRegion, sent: m.UnsafeRegionMsg) -> dict[str, object]:
    return {
        "uas_id": region.uas_id,
        "track_id": region.track_id,
        "center_enu_m": _listed(region.center_enu_m),
        "cov_enu_m2": _listed(region.cov_enu_m2),
        "v_enu_m_s": _listed(region.v_enu_m_s),
        "chi2_threshold": float(region.chi2_threshold),
        "alpha": float(region.alpha),
        "valid_until_s": sent.valid_until_s,
        "semi_axes_m": _listed(region.semi_axes_m),
        "flags": sent.flags,
    }
