r"""Foxglove views of a run: JSON schemas and message builders (pure functions, no I/O).

The recorder (``ridsafe.tools.recorder``) derives these typed channels from the run's own
records so that ``OUT/run.mcap`` opens usefully in Foxglove (3D and Map panels):

=============================  =========================  ==============================
topic                          schema                     from
=============================  =========================  ==============================
``/foxglove/tf``               ``foxglove.FrameTransform`` once, t = 0: "world" -> "enu"
``/foxglove/aircraft``         ``foxglove.SceneUpdate``    every ``/truth/vehicles``
``/foxglove/unsafe_regions``   ``foxglove.SceneUpdate``    every ``/gcs/unsafe_regions``
``/foxglove/location/<sysid>`` ``foxglove.LocationFix``    ``/truth/vehicles`` at 1 Hz
=============================  =========================  ==============================

The schemas are written from the documented Foxglove message definitions
(docs.foxglove.dev, "Message schemas"): ``time``/``duration`` are ``{sec, nsec}``, vectors
``{x, y, z}``, quaternions ``{x, y, z, w}``, colours ``{r, g, b, a}`` in [0, 1]. Foxglove
recognises a channel by its schema *name*; the JSON schema text is documentation.

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

__all__ = [
    "AIRCRAFT_TOPIC",
    "ENU_FRAME",
    "REGIONS_TOPIC",
    "SCHEMAS",
    "TF_TOPIC",
    "WORLD_FRAME",
    "aircraft_scene",
    "ellipsoid_axes",
    "location_fixes",
    "location_topic",
    "marker_entity",
    "quaternion_from_matrix",
    "regions_scene",
    "timestamp",
    "world_to_enu_transform",
]

FloatArray = NDArray[np.float64]
Json = dict[str, Any]

AIRCRAFT_TOPIC = "/foxglove/aircraft"
REGIONS_TOPIC = "/foxglove/unsafe_regions"
TF_TOPIC = "/foxglove/tf"
LOCATION_TOPIC_PREFIX = "/foxglove/location/"
WORLD_FRAME = "world"
ENU_FRAME = "enu"

SCENE_UPDATE = "foxglove.SceneUpdate"
LOCATION_FIX = "foxglove.LocationFix"
FRAME_TRANSFORM = "foxglove.FrameTransform"

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
LABEL_COLOUR: RGBA = (1.00, 1.00, 1.00, 1.00)


def location_topic(sysid: int) -> str:
    return f"{LOCATION_TOPIC_PREFIX}{sysid}"


# --------------------------------------------------------------------------------------------
# JSON schemas (from the documented definitions)


def _number(description: str) -> Json:
    return {"type": "number", "description": description}


def _object(title: str, description: str, properties: Json) -> Json:
    return {
        "title": title,
        "description": description,
        "type": "object",
        "properties": properties,
        "required": list(properties),
    }


def _stamp(title: str, description: str) -> Json:
    return {
        "title": title,
        "description": description,
        "type": "object",
        "properties": {
            "sec": {"type": "integer", "minimum": 0},
            "nsec": {"type": "integer", "minimum": 0, "maximum": 999_999_999},
        },
        "required": ["sec", "nsec"],
    }


def _vector3(description: str) -> Json:
    axes = {axis: _number(f"{axis} component") for axis in "xyz"}
    return _object("foxglove.Vector3", description, axes)


def _quaternion(description: str) -> Json:
    parts = {part: _number(f"{part} value") for part in "xyzw"}
    return _object("foxglove.Quaternion", description, parts)


def _color(description: str) -> Json:
    channels = {c: _number(f"{c} channel, 0-1") for c in "rgba"}
    return _object("foxglove.Color", description, channels)


def _pose(description: str) -> Json:
    return _object(
        "foxglove.Pose",
        description,
        {
            "position": _vector3("Point denoting position in 3D space"),
            "orientation": _quaternion("Quaternion denoting orientation in 3D space"),
        },
    )


def _array(items: Json, description: str) -> Json:
    return {"type": "array", "items": items, "description": description}


def _key_values() -> Json:
    pair = _object(
        "foxglove.KeyValuePair",
        "A key with its associated value",
        {"key": {"type": "string"}, "value": {"type": "string"}},
    )
    return _array(pair, "Additional user-provided metadata; keys must be unique")


def _shape_primitive(title: str, what: str) -> Json:
    return _object(
        title,
        f"A primitive representing a {what}",
        {
            "pose": _pose(f"Position of the centre and orientation of the {what}"),
            "size": _vector3("Size (diameter) along each axis"),
            "color": _color(f"Color of the {what}"),
        },
    )


def _text_primitive() -> Json:
    return _object(
        "foxglove.TextPrimitive",
        "A primitive representing a text label",
        {
            "pose": _pose("Position of the centre of the text box and orientation of the text"),
            "billboard": {"type": "boolean", "description": "always face the camera"},
            "font_size": _number("Font size (height of one line of text)"),
            "scale_invariant": {"type": "boolean", "description": "font_size in pixels"},
            "color": _color("Color of the text"),
            "text": {"type": "string"},
        },
    )


def _other_primitives(title: str) -> Json:
    """Primitive kinds this project never writes: described loosely (objects)."""
    return _array({"title": title, "type": "object"}, f"{title} primitives")


def _scene_entity() -> Json:
    entity = _object(
        "foxglove.SceneEntity",
        "A visual element in a 3D scene; its primitives share one frame of reference",
        {
            "timestamp": _stamp("time", "Timestamp of the entity"),
            "frame_id": {"type": "string", "description": "Frame of reference"},
            "id": {"type": "string", "description": "Replaces a prior entity with this id"},
            "lifetime": _stamp("duration", "Removed after this long; zero: never"),
            "frame_locked": {"type": "boolean"},
            "metadata": _key_values(),
            "arrows": _other_primitives("foxglove.ArrowPrimitive"),
            "cubes": _array(_shape_primitive("foxglove.CubePrimitive", "cube"), "Cubes"),
            "spheres": _array(
                _shape_primitive("foxglove.SpherePrimitive", "sphere or ellipsoid"), "Spheres"
            ),
            "cylinders": _other_primitives("foxglove.CylinderPrimitive"),
            "lines": _other_primitives("foxglove.LinePrimitive"),
            "triangles": _other_primitives("foxglove.TriangleListPrimitive"),
            "texts": _array(_text_primitive(), "Text primitives"),
            "models": _other_primitives("foxglove.ModelPrimitive"),
        },
    )
    return entity


def _scene_update_schema() -> Json:
    deletion = _object(
        "foxglove.SceneEntityDeletion",
        "Command to remove previously published entities",
        {
            "timestamp": _stamp("time", "Only matching entities earlier than this are deleted"),
            "type": {"type": "integer", "description": "0 MATCHING_ID, 1 ALL"},
            "id": {"type": "string", "description": "Identifier for MATCHING_ID"},
        },
    )
    return _object(
        SCENE_UPDATE,
        "An update to the entities displayed in a 3D scene",
        {
            "deletions": _array(deletion, "Scene entities to delete"),
            "entities": _array(_scene_entity(), "Scene entities to add or replace"),
        },
    )


def _location_fix_schema() -> Json:
    schema = _object(
        LOCATION_FIX,
        "A navigation satellite fix for any Global Navigation Satellite System",
        {
            "timestamp": _stamp("time", "Timestamp of the message"),
            "frame_id": {"type": "string", "description": "Frame for the sensor"},
            "latitude": _number("Latitude in degrees"),
            "longitude": _number("Longitude in degrees"),
            "altitude": _number("Altitude in meters"),
            "position_covariance": {
                "type": "array",
                "items": {"type": "number"},
                "minItems": 9,
                "maxItems": 9,
                "description": "ENU covariance (m^2), row-major",
            },
            "position_covariance_type": {
                "type": "integer",
                "description": "0 UNKNOWN, 1 APPROXIMATED, 2 DIAGONAL_KNOWN, 3 KNOWN",
            },
            "color": _color("Color used to visualize the location"),
        },
    )
    schema["required"] = [name for name in schema["required"] if name != "color"]
    return schema


def _frame_transform_schema() -> Json:
    return _object(
        FRAME_TRANSFORM,
        "A transform between two reference frames in 3D space",
        {
            "timestamp": _stamp("time", "Timestamp of transform"),
            "parent_frame_id": {"type": "string", "description": "Name of the parent frame"},
            "child_frame_id": {"type": "string", "description": "Name of the child frame"},
            "translation": _vector3("Translation component of the transform"),
            "rotation": _quaternion("Rotation component of the transform"),
        },
    )


#: schema name -> JSON schema (register with encoding "jsonschema", messages "json").
SCHEMAS: Mapping[str, Json] = {
    SCENE_UPDATE: _scene_update_schema(),
    LOCATION_FIX: _location_fix_schema(),
    FRAME_TRANSFORM: _frame_transform_schema(),
}


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
    shown until the region's ``valid_until_s``."""
    semi_axes, rotation = ellipsoid_axes(region["cov_enu_m2"], float(region["chi2_threshold"]))
    sphere = {
        "pose": {
            "position": _vec(region["center_enu_m"]),
            "orientation": _quat(quaternion_from_matrix(rotation)),
        },
        "size": _vec(2.0 * semi_axes),
        "color": _rgba(REGION_COLOUR),
    }
    valid_until = region.get("valid_until_s")
    lifetime = 0.0 if valid_until is None else max(valid_until - t_s, MIN_REGION_LIFETIME_S)
    uas_id = str(region["uas_id"])
    entity = _entity(
        t_s,
        f"region/{uas_id}",
        spheres=[sphere],
        texts=[_label(region["center_enu_m"], f"unsafe {uas_id}")],
        lifetime_s=lifetime,
        metadata={"uas_id": uas_id, "track_id": str(region.get("track_id"))},
    )
    return {"deletions": [], "entities": [entity]}
