"""Foxglove message schemas (JSON schema) for the run log's derived channels.

Written from the documented Foxglove message definitions (docs.foxglove.dev, "Message
schemas"): ``time``/``duration`` are ``{sec, nsec}``, vectors ``{x, y, z}``, quaternions
``{x, y, z, w}``, colours ``{r, g, b, a}`` in [0, 1]. Foxglove recognises a channel by its
schema *name*; the JSON schema text is documentation. Primitive kinds this project never
writes are described loosely (as objects).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["FRAME_TRANSFORM", "LOCATION_FIX", "SCENE_UPDATE", "SCHEMAS"]

Json = dict[str, Any]

SCENE_UPDATE = "foxglove.SceneUpdate"
LOCATION_FIX = "foxglove.LocationFix"
FRAME_TRANSFORM = "foxglove.FrameTransform"


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
