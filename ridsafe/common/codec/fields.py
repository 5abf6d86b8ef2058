"""Domain messages <-> MAVLink field-value dicts: the form ASTM F3411 encoding works on.

``common.f3411`` speaks the field values of the OPEN_DRONE_ID_* messages (degE7, cm/s, ...);
these two functions connect it to the domain messages without knowing any scale themselves.
"""

from __future__ import annotations

from typing import Any

from ridsafe.common import messages as m
from ridsafe.common.codec.registry import from_mavlink, to_wire, wire_plan
from ridsafe.common.dialect import ridsafe_v20 as mav
from ridsafe.common.errors import WireError


def odid_fields(message: m.Message) -> tuple[str, dict[str, object]]:
    """MAVLink message name and field values (the form F3411 encoding works on): the
    arguments a pymavlink message would be built from, extensions defaulted, char arrays as
    text and arrays as lists."""
    wire = to_wire(message)
    defaults = wire_plan(wire.cls)[3]
    args = wire.args + defaults[len(wire.args) :]
    names = wire.cls.fieldnames
    fields = {name: _plain(value) for name, value in zip(names, args, strict=True)}
    return wire.cls.msgname, fields


def message_from_fields(name: str, fields: dict[str, object]) -> m.Message:
    """The domain message for MAVLink field values (inverse of ``odid_fields``)."""
    cls = mav.mavlink_map.get(getattr(mav, "MAVLINK_MSG_ID_" + name, -1))
    if cls is None:
        raise WireError(f"unknown MAVLink message {name!r}")
    values = {k: (v.encode("latin-1") if isinstance(v, str) else v) for k, v in fields.items()}
    raw = cls(**values)
    decoded = from_mavlink(raw)
    if decoded is None:
        raise WireError(f"{name} has no domain message")
    return decoded


def _plain(value: Any) -> object:
    if isinstance(value, bytes):
        return value.rstrip(b"\x00").decode("latin-1")
    return list(value) if isinstance(value, list | tuple) else value
