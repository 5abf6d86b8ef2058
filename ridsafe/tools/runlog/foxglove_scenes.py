r"""Foxglove views of a run's records: pure message builders, no I/O.

What the derived channels (``ridsafe.tools.runlog.foxglove_channels``) write: the aircraft
scene (:func:`aircraft_scene`), the unsafe-region ellipsoids (:func:`regions_scene`), a
``LocationFix`` per vehicle (:func:`location_fixes`) and the "world" -> "enu" transform
(:func:`world_to_enu_transform`); the schemas are in ``foxglove_schemas``.

Unsafe region as an ellipsoid. The region ``(x - c)^T P^-1 (x - c) <= chi2`` has principal
axes the eigenvectors ``v_k`` of ``P`` (``P = V diag(lambda) V^T``, ``numpy.linalg.eigh``) and
semi-axes ``a_k = sqrt(chi2 * lambda_k)``. A Foxglove sphere primitive is the unit sphere
scaled by ``size / 2`` along its own x, y, z and then rotated by ``pose.orientation``, so::

    size = 2 a = (2 a_0, 2 a_1, 2 a_2),   orientation = quaternion of R = [v_0 v_1 v_2]

with one eigenvector negated when ``det V = -1`` so that ``R`` is a proper rotation.
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ridsafe.common.frames import GeodeticOrigin, enu_to_geodetic
from ridsafe.common.mav_enums import RegionFlags

__all__ = [
    "ENU_FRAME",
    "WORLD_FRAME",
    "aircraft_scene",
    "ellipsoid_axes",
    "location_fixes",
    "marker_entity",
    "quaternion_from_matrix",
    "regions_scene",
    "timestamp",
    "world_to_enu_transform",
]

FloatArray = NDArray[np.float64]
Json = dict[str, Any]

WORLD_FRAME = "world"
ENU_FRAME = "enu"

#: Diameter of the aircraft markers: real octorotors are ~1.5 m, invisible over 1 km.
AIRCRAFT_MARKER_M = 8.0
LABEL_FONT_PX = 14.0
#: A region shown for at least this long even when its validity has already run out.
MIN_REGION_LIFETIME_S = 0.1

RGBA = tuple[float, float, float, float]
BENIGN_COLOUR: RGBA = (0.20, 0.55, 1.00, 1.00)
SPOOFER_COLOUR: RGBA = (1.00, 0.15, 0.10, 1.00)
CLAIMED_COLOUR: RGBA = (1.00, 0.15, 0.10, 0.35)
REGION_COLOUR: RGBA = (1.00, 0.55, 0.00, 0.25)
#: A stranger's region, no alert standing (``RegionFlags.UNCONFIRMED``).
UNCONFIRMED_REGION_COLOUR: RGBA = (1.00, 0.90, 0.20, 0.20)
LABEL_COLOUR: RGBA = (1.00, 1.00, 1.00, 1.00)


# --------------------------------------------------------------------------------------------
# Small builders


def timestamp(t_s: float) -> Json:
    """Seconds -> Foxglove ``time``/``duration`` ``{sec, nsec}`` (t_s >= 0)."""
    total_ns = round(t_s * 1e9)
    sec, nsec = divmod(total_ns, 1_000_000_000)
    return {"sec": sec, "nsec": nsec}


def _vec(p: Sequence[float] | FloatArray) -> Json:
    return {"x": float(p[0]), "y": float(p[1]), "z": float(p[2])}


def _quat(q: Sequence[float]) -> Json:
    return {"x": q[0], "y": q[1], "z": q[2], "w": q[3]}


def _rgba(c: RGBA) -> Json:
    return {"r": c[0], "g": c[1], "b": c[2], "a": c[3]}


_IDENTITY_Q = (0.0, 0.0, 0.0, 1.0)


def _sphere(center: Sequence[float] | FloatArray, size: Sequence[float], colour: RGBA) -> Json:
    return {
        "pose": {"position": _vec(center), "orientation": _quat(_IDENTITY_Q)},
        "size": _vec(size),
        "color": _rgba(colour),
    }


def _label(center: Sequence[float] | FloatArray, text: str) -> Json:
    above = (float(center[0]), float(center[1]), float(center[2]) + AIRCRAFT_MARKER_M)
    return {
        "pose": {"position": _vec(above), "orientation": _quat(_IDENTITY_Q)},
        "billboard": True,
        "font_size": LABEL_FONT_PX,
        "scale_invariant": True,
        "color": _rgba(LABEL_COLOUR),
        "text": text,
    }


def _entity(
    t_s: float,
    entity_id: str,
    *,
    spheres: list[Json],
    texts: Sequence[Json] = (),
    lifetime_s: float = 0.0,
    metadata: Mapping[str, str] | None = None,
) -> Json:
    return {
        "timestamp": timestamp(t_s),
        "frame_id": ENU_FRAME,
        "id": entity_id,
        "lifetime": timestamp(lifetime_s),
        "frame_locked": False,
        "metadata": [{"key": k, "value": v} for k, v in (metadata or {}).items()],
        "arrows": [],
        "cubes": [],
        "spheres": spheres,
        "cylinders": [],
        "lines": [],
        "triangles": [],
        "texts": list(texts),
        "models": [],
    }


def world_to_enu_transform(t_s: float = 0.0) -> Json:
    """``foxglove.FrameTransform``: the scenario's ENU frame is Foxglove's "world" frame."""
    return {
        "timestamp": timestamp(t_s),
        "parent_frame_id": WORLD_FRAME,
        "child_frame_id": ENU_FRAME,
        "translation": _vec((0.0, 0.0, 0.0)),
        "rotation": _quat(_IDENTITY_Q),
    }


# --------------------------------------------------------------------------------------------
# Aircraft


def marker_entity(
    t_s: float,
    entity_id: str,
    p_enu_m: Sequence[float],
    colour: RGBA,
    text: str,
    metadata: Mapping[str, str] | None = None,
) -> Json:
    """One aircraft marker as a ``foxglove.SceneEntity``: a sphere of ``AIRCRAFT_MARKER_M``
    at ``p_enu_m`` with a text label above it. (The dict form of what :func:`aircraft_scene`
    writes as text.)"""
    marker = (AIRCRAFT_MARKER_M,) * 3
    return _entity(
        t_s,
        entity_id,
        spheres=[_sphere(p_enu_m, marker, colour)],
        texts=[_label(p_enu_m, text)],
        metadata=metadata,
    )


def _dumps(value: Any) -> str:
    return json.dumps(value, separators=(",", ":"))


def _xyz_json(x: float, y: float, z: float) -> str:
    return f'{{"x":{x!r},"y":{y!r},"z":{z!r}}}'


# Constant fragments of a marker entity, encoded once. Key order differs from marker_entity's
# dict; JSON objects are unordered.
_IDENTITY_JSON = _dumps(_quat(_IDENTITY_Q))
_MARKER_SIZE_JSON = _dumps(_vec((AIRCRAFT_MARKER_M,) * 3))
_LABEL_REST_JSON = (
    f',"orientation":{_IDENTITY_JSON}}},"billboard":true,"font_size":{LABEL_FONT_PX!r},'
    f'"scale_invariant":true,"color":{_dumps(_rgba(LABEL_COLOUR))},"text":'
)
_ENTITY_TAIL_JSON = (
    ',"lifetime":{"sec":0,"nsec":0},"frame_locked":false,'
    '"arrows":[],"cubes":[],"cylinders":[],"lines":[],"triangles":[],"models":[]}'
)


def _marker_entity_json(
    stamp_json: str,
    entity_id: str,
    p: tuple[float, float, float],
    colour_json: str,
    text: str,
    metadata: Mapping[str, str] | None = None,
) -> str:
    """:func:`marker_entity` as JSON text, built from pre-encoded fragments: the aircraft
    scene is written at 10 Hz and the generic encoder made it the recorder's largest cost."""
    x, y, z = p
    head, text_json = _marker_strings(entity_id, text, tuple((metadata or {}).items()))
    return (
        f'{{"timestamp":{stamp_json},{head},'
        f'"spheres":[{{"pose":{{"position":{_xyz_json(x, y, z)},"orientation":{_IDENTITY_JSON}}},'
        f'"size":{_MARKER_SIZE_JSON},"color":{colour_json}}}],'
        f'"texts":[{{"pose":{{"position":{_xyz_json(x, y, z + AIRCRAFT_MARKER_M)}'
        f"{_LABEL_REST_JSON}{text_json}}}]{_ENTITY_TAIL_JSON}"
    )


@functools.lru_cache(maxsize=4096)
def _marker_strings(
    entity_id: str, text: str, metadata: tuple[tuple[str, str], ...]
) -> tuple[str, str]:
    """The encoded frame/id/metadata members and the encoded label text (few distinct)."""
    pairs = [{"key": k, "value": v} for k, v in metadata]
    head = f'"frame_id":"{ENU_FRAME}","id":{_dumps(entity_id)},"metadata":{_dumps(pairs)}'
    return head, _dumps(text)


_BENIGN_JSON = _dumps(_rgba(BENIGN_COLOUR))
_SPOOFER_JSON = _dumps(_rgba(SPOOFER_COLOUR))
_CLAIMED_JSON = _dumps(_rgba(CLAIMED_COLOUR))


def _finite_point(p: Any) -> tuple[float, float, float] | None:
    """``p`` as three finite floats, or None (null or non-finite coordinates)."""
    if p is None or len(p) != 3 or any(c is None for c in p):
        return None
    x, y, z = float(p[0]), float(p[1]), float(p[2])
    return (x, y, z) if math.isfinite(x + y + z) else None


def aircraft_scene(t_s: float, truth: Mapping[str, Any]) -> str:
    """``foxglove.SceneUpdate`` (as JSON text) from a ``/truth/vehicles`` record: one
    :func:`marker_entity` per vehicle (``vehicle/<sysid>``, label the sysid; the spoofer red
    and labelled "<sysid> spoofer", benign blue; metadata sysid and armed) and the spoofer's
    claimed RID position as a translucent one (``spoofer/claimed``, "<sysid> claimed").
    Vehicles without a finite position are left out."""
    stamp = _dumps(timestamp(t_s))
    spoofer = truth.get("spoofer_sysid")
    armed = truth.get("armed") or []
    entities = []
    for k, (sysid, position) in enumerate(zip(truth["sysid"], truth["p_enu_m"], strict=True)):
        p = _finite_point(position)
        if p is None:
            continue
        is_spoofer = sysid == spoofer
        meta = {"sysid": str(sysid), "armed": str(bool(armed[k])) if k < len(armed) else "?"}
        entities.append(
            _marker_entity_json(
                stamp,
                f"vehicle/{sysid}",
                p,
                _SPOOFER_JSON if is_spoofer else _BENIGN_JSON,
                f"{sysid} spoofer" if is_spoofer else str(sysid),
                meta,
            )
        )
    claimed = _finite_point(truth.get("spoofer_claimed_p_enu_m"))
    if claimed is not None:
        text = f"{spoofer} claimed"
        entities.append(_marker_entity_json(stamp, "spoofer/claimed", claimed, _CLAIMED_JSON, text))
    return f'{{"deletions":[],"entities":[{",".join(entities)}]}}'


def location_fixes(
    t_s: float, truth: Mapping[str, Any], origin: GeodeticOrigin
) -> list[tuple[int, Json]]:
    """``(sysid, foxglove.LocationFix)`` for each vehicle of a ``/truth/vehicles`` record."""
    sysids = [int(s) for s in truth["sysid"]]
    p = np.array(truth["p_enu_m"], dtype=np.float64).reshape(len(sysids), 3)
    lat, lon, alt = enu_to_geodetic(origin, p)
    spoofer = truth.get("spoofer_sysid")
    fixes = []
    for k, sysid in enumerate(sysids):
        if not (math.isfinite(lat[k]) and math.isfinite(lon[k]) and math.isfinite(alt[k])):
            continue
        fixes.append(
            (
                sysid,
                {
                    "timestamp": timestamp(t_s),
                    "frame_id": "",
                    "latitude": float(lat[k]),
                    "longitude": float(lon[k]),
                    "altitude": float(alt[k]),
                    "position_covariance": [0.0] * 9,
                    "position_covariance_type": 0,
                    "color": _rgba(SPOOFER_COLOUR if sysid == spoofer else BENIGN_COLOUR),
                },
            )
        )
    return fixes


# --------------------------------------------------------------------------------------------
# Unsafe regions


def quaternion_from_matrix(r: ArrayLike) -> tuple[float, float, float, float]:
    """Proper rotation matrix (3, 3) -> unit quaternion (x, y, z, w) with w >= 0.

    Shepperd's method: take the largest of (trace, R00, R11, R22) as the pivot so the
    square root is never of a small number.
    """
    m = np.asarray(r, dtype=np.float64)
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    diag = (m[0, 0], m[1, 1], m[2, 2])
    k = int(np.argmax(diag))
    if trace >= diag[k]:
        s = 2.0 * math.sqrt(1.0 + trace)
        q = (
            (m[2, 1] - m[1, 2]) / s,
            (m[0, 2] - m[2, 0]) / s,
            (m[1, 0] - m[0, 1]) / s,
            s / 4.0,
        )
    else:
        i, j, h = k, (k + 1) % 3, (k + 2) % 3
        s = 2.0 * math.sqrt(1.0 + m[i, i] - m[j, j] - m[h, h])
        v = [0.0, 0.0, 0.0]
        v[i] = s / 4.0
        v[j] = (m[j, i] + m[i, j]) / s
        v[h] = (m[h, i] + m[i, h]) / s
        q = (v[0], v[1], v[2], (m[h, j] - m[j, h]) / s)
    norm = math.sqrt(sum(c * c for c in q))
    sign = -1.0 if q[3] < 0.0 else 1.0
    x, y, z, w = (sign * c / norm for c in q)
    return (x, y, z, w)


def ellipsoid_axes(cov_m2: ArrayLike, chi2_threshold: float) -> tuple[FloatArray, FloatArray]:
    """Semi-axes ``a`` (3,) and proper rotation ``R`` (3, 3) whose column k is the direction
    of ``a[k]``, for ``{x : x^T P^-1 x <= chi2}`` (eigenvalues clamped at 0)."""
    p = np.asarray(cov_m2, dtype=np.float64).reshape(3, 3)
    eigenvalues, vectors = np.linalg.eigh(0.5 * (p + p.T))
    semi_axes = np.sqrt(chi2_threshold * np.clip(eigenvalues, 0.0, None))
    rotation = vectors.copy()
    if np.linalg.det(rotation) < 0.0:
        rotation[:, 2] = -rotation[:, 2]
    return semi_axes, rotation


def regions_scene(t_s: float, region: Mapping[str, Any]) -> Json:
    """``foxglove.SceneUpdate`` from a ``/gcs/unsafe_regions`` record: one ellipsoid entity
    ``region/<uas_id>`` (sphere with size = 2 semi-axes, oriented along the principal axes),
    shown until the region's ``valid_until_s``; a stranger's (flagged UNCONFIRMED) in its
    own colour, labelled "stranger"."""
    unconfirmed = bool(int(region.get("flags", 0)) & RegionFlags.UNCONFIRMED)
    semi_axes, rotation = ellipsoid_axes(region["cov_enu_m2"], float(region["chi2_threshold"]))
    sphere = {
        "pose": {
            "position": _vec(region["center_enu_m"]),
            "orientation": _quat(quaternion_from_matrix(rotation)),
        },
        "size": _vec(2.0 * semi_axes),
        "color": _rgba(UNCONFIRMED_REGION_COLOUR if unconfirmed else REGION_COLOUR),
    }
    valid_until = region.get("valid_until_s")
    lifetime = 0.0 if valid_until is None else max(valid_until - t_s, MIN_REGION_LIFETIME_S)
    uas_id = str(region["uas_id"])
    kind = "stranger" if unconfirmed else "unsafe"
    entity = _entity(
        t_s,
        f"region/{uas_id}",
        spheres=[sphere],
        texts=[_label(region["center_enu_m"], f"{kind} {uas_id}")],
        lifetime_s=lifetime,
        metadata={"uas_id": uas_id, "track_id": str(region.get("track_id"))},
    )
    return {"deletions": [], "entities": [entity]}
