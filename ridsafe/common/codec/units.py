"""MAVLink units and Open Drone ID sentinels: the scale helpers every conversion module uses.

Scales (common.xml): lat/lon degE7, altitudes mm (GLOBAL_POSITION_INT, HOME_POSITION),
velocities cm/s, headings cdeg, times ms/us. Open Drone ID "unknown" sentinels map to None.
``Wire`` is a message on its way out: its pymavlink class and the constructor arguments.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

from ridsafe.common import messages as m
from ridsafe.common.errors import WireError

DEG_E7 = 1e7
ODID_UNKNOWN_DIRECTION_CDEG = 36100
ODID_UNKNOWN_SPEED_H_CMS = 25500
ODID_UNKNOWN_SPEED_V_CMS = 6300
ODID_UNKNOWN_ALT_M = -1000.0
ODID_UNKNOWN_TIMESTAMP_S = 0xFFFF
ODID_ID_LEN = 20


# --- small conversion helpers -----------------------------------------------------------


def id20(raw: bytes) -> list[int]:
    if len(raw) > ODID_ID_LEN:
        raise WireError(f"id is {len(raw)} bytes, at most {ODID_ID_LEN} fit")
    return list(raw.ljust(ODID_ID_LEN, b"\x00"))


def id_from_wire(values: Any) -> bytes:
    """A decoded uint8[20] id field as bytes without its NUL padding."""
    raw = values.encode("latin-1") if isinstance(values, str) else bytes(values)
    return raw.rstrip(b"\x00")


def check_lat_lon(lat_deg: float, lon_deg: float, what: str) -> None:
    if not (abs(lat_deg) <= 90.0 and abs(lon_deg) <= 180.0):
        raise WireError(f"{what}: latitude {lat_deg} / longitude {lon_deg} out of range")


def check_finite(what: str, *values: float) -> None:
    for value in values:
        if not math.isfinite(value):
            raise WireError(f"{what}: non-finite value {value}")


def deg_e7(value_deg: float) -> int:
    return round(value_deg * DEG_E7)


def or_unknown(value: float | None, unknown: float) -> float:
    return unknown if value is None else value


def unknown_to_none(value: float, unknown: float) -> float | None:
    return None if value == unknown else value


def vec3(a: float, b: float, c: float) -> m.Vec3:
    return (float(a), float(b), float(c))


# --- the outbound form ---------------------------------------------------------------------


class Wire(NamedTuple):
    """A message on its way out: its pymavlink class and that class's constructor arguments
    (the fields in XML order, MAVLink units). Packed straight into bytes on the hot path
    (``wire.encode_payload``); made into a pymavlink object only when asked (``to_mavlink``)."""

    cls: Any
    args: tuple[Any, ...]


def wire(cls: Any, *args: Any) -> Wire:
    return Wire(cls, args)


ToMav = Callable[[Any], Wire]
FromMav = Callable[[Any], m.Message]
#: domain class -> (MAVLink message name, to-MAVLink, from-MAVLink)
CodecTable = dict[type, tuple[str, ToMav, FromMav]]


# --- time and speed scales ----------------------------------------------------------------


def ms(t_s: float) -> int:
    """Seconds -> a uint32 millisecond field (wraps like time_boot_ms)."""
    return round(t_s * 1000.0) & 0xFFFFFFFF


def cms(v_m_s: float) -> int:
    """m/s -> an int16 cm/s field (saturating, also where the cm/s overflow a float)."""
    return max(-32768, min(32767, saturating_round(v_m_s * 100.0)))


def saturating_round(value: float) -> int:
    """``round``, with an infinite value (a finite one scaled past float's range) taken as
    an integer beyond every field; NaN is the caller's to refuse."""
    if math.isinf(value):
        return 2**63 if value > 0.0 else -(2**63)
    return round(value)


def text(value: bytes | str) -> str:
    """A decoded char array as text (NUL padding dropped)."""
    return value if isinstance(value, str) else value.rstrip(b"\x00").decode("ascii", "replace")


def us(t_s: float) -> int:
    """Seconds -> a uint64 microsecond field (never negative)."""
    return max(0, round(t_s * 1e6))


def uas_id_bytes(uas_id: str) -> bytes:
    raw = uas_id.encode("ascii")
    if len(raw) > ODID_ID_LEN:
        raise WireError(f"uas_id {uas_id!r} is longer than {ODID_ID_LEN} characters")
    return raw
