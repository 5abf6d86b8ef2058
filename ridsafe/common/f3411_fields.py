"""Field-level pieces of the ASTM F3411 codec; the public face is :mod:`ridsafe.common.f3411`.

What lives here, so that the message module reads as a table of byte layouts:

* the error hierarchy (re-exported by ``f3411``);
* MAVLink field types (``uint8_t``, ``float``, ``uint8_t[20]``, ``char[23]`` ...). Each checks a
  caller's value and turns it into a canonical Python value (``int``, ``numpy.float32``, ``bytes``),
  and turns a decoded value back into what pymavlink holds (``list[int]`` for ``uint8_t[n]``,
  ``str`` for ``char[n]``);
* the field lists of the ``OPEN_DRONE_ID_*`` messages (:data:`MAVLINK_FIELDS`) and a reader that
  checks a caller's field values against them;
* the scalar quantisers between MAVLink units and F3411 wire integers.

The quantisers reproduce the reference C library (opendroneid-core-c) bit for bit. It converts
each MAVLink integer to a C ``float`` (float32) in SI units, then quantises::

    direction    d = (float) cdeg / 100;  n = roundf(d);  n == 360 -> 0
                 n < 180 -> byte n, E/W bit 0;  n >= 180 -> byte n - 180, E/W bit 1
    speed_h      s = (float) cm_s / 100
                 s <= 63.75 -> byte roundf(s / 0.25), multiplier bit 0
                 s >  63.75 -> byte roundf((s - 63.75) / 0.75), multiplier bit 1
    speed_v      (int) (((float) cm_s / 100) / 0.5)           truncated toward zero
    lat, lon     round((double) degE7 / 1e7 * 1e7)            double precision
    altitude     (int) ((alt_m + 1000) / 0.5)                 truncated toward zero
    timestamp    roundf(t_s * 10);  65535 (unknown) is sent as 0xFFFF
    area_radius  radius_m / 10                                integer division

``roundf`` rounds halves away from zero and every step above is float32, so neither Python's
``round`` (halves to even) nor float64 arithmetic gives the same bytes near half-way points.
Results are clamped to the wire integer's range as the reference does (never reached for
inputs that pass the range checks).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ridsafe.common.errors import RidsafeError, WireError

_F32 = np.float32
_F32_SAFE = 1e38  # |x| below this rounds to a finite float32 (the largest is ~3.4e38)


# --- errors -----------------------------------------------------------------------------------


class F3411Error(RidsafeError, ValueError):
    """Base of every error the F3411 codec raises."""


class F3411EncodeError(F3411Error):
    """Field values the reference encoder rejects.

    ``message_name`` is the MAVLink message, ``field`` the offending field (``None`` when the
    problem is the message as a whole) and ``problem`` says what was expected and what came.
    """

    def __init__(self, message_name: str, field: str | None, problem: str) -> None:
        self.message_name = message_name
        self.field = field
        self.problem = problem
        where = message_name if field is None else f"{message_name}.{field}"
        super().__init__(f"{where}: {problem}")


class F3411FieldError(F3411EncodeError):
    """A value that is no value of its MAVLink field: missing, unknown, wrong type or size."""


class F3411DecodeError(F3411Error, WireError):
    """Bytes that are no well-formed F3411 message: wrong length, type or protocol version."""


# --- MAVLink field types ----------------------------------------------------------------------

Canonical = int | np.float32 | bytes
"""A checked field value: integers as ``int``, ``float`` as float32, arrays as ``bytes``."""

WireValue = int | float | bytes
"""A value decoded from the wire, before it is shaped into what pymavlink holds."""


@dataclass(frozen=True)
class IntType:
    """A MAVLink integer field (``uint8_t`` ... ``uint32_t``)."""

    c_name: str
    lo: int
    hi: int

    def check(self, message: str, field: str, value: object) -> int:
        if isinstance(value, bool) or not isinstance(value, int | np.integer):
            raise F3411FieldError(message, field, f"expected {self.c_name}, got {value!r}")
        number = int(value)
        if not self.lo <= number <= self.hi:
            raise F3411FieldError(
                message, field, f"{number} does not fit {self.c_name} ({self.lo}..{self.hi})"
            )
        return number

    def to_mavlink(self, value: WireValue) -> object:
        return value


@dataclass(frozen=True)
class FloatType:
    """A MAVLink ``float`` field; values are rounded to float32 as the MAVLink wire does."""

    c_name: str = "float"

    def check(self, message: str, field: str, value: object) -> np.float32:
        if isinstance(value, bool) or not isinstance(value, int | float | np.number):
            raise F3411FieldError(message, field, f"expected a number, got {value!r}")
        if type(value) is float and -_F32_SAFE < value < _F32_SAFE:  # no overflow possible
            return _F32(value)
        with np.errstate(over="ignore"):
            as_f32 = _F32(value)
        if not np.isfinite(as_f32):
            raise F3411FieldError(message, field, f"expected a finite float32, got {value!r}")
        return as_f32

    def to_mavlink(self, value: WireValue) -> object:
        return float(value)


def _plain_octets(values: Sequence[object]) -> bytes | None:
    """``bytes(values)`` when every value is a plain ``int`` in 0..255 (no bools, no numpy
    scalars: those take the checked path), else None."""
    if not set(map(type, values)) <= {int}:
        return None
    try:
        return bytes(values)  # type: ignore[arg-type]
    except ValueError:  # out of 0..255
        return None


@dataclass(frozen=True)
class BytesType:
    """A MAVLink ``uint8_t[n]`` field: a list of ints; shorter lists are padded with zeros."""

    size: int

    @property
    def c_name(self) -> str:
        return f"uint8_t[{self.size}]"

    def check(self, message: str, field: str, value: object) -> bytes:
        if isinstance(value, bytes | bytearray):
            raw = bytes(value)
        elif isinstance(value, Sequence) and not isinstance(value, str):
            plain = _plain_octets(value)
            if plain is None:  # not all plain ints in 0..255: say which one is not
                items = [U8.check(message, f"{field}[{i}]", v) for i, v in enumerate(value)]
                plain = bytes(items)
            raw = plain
        else:
            raise F3411FieldError(message, field, f"expected a list of ints, got {value!r}")
        if len(raw) > self.size:
            raise F3411FieldError(message, field, f"{len(raw)} bytes do not fit {self.c_name}")
        return raw.ljust(self.size, b"\0")

    def to_mavlink(self, value: WireValue) -> object:
        assert isinstance(value, bytes)
        return list(value.ljust(self.size, b"\0"))


@dataclass(frozen=True)
class CharsType:
    """A MAVLink ``char[n]`` field: an ASCII ``str``, NUL-padded on the wire."""

    size: int

    @property
    def c_name(self) -> str:
        return f"char[{self.size}]"

    def check(self, message: str, field: str, value: object) -> bytes:
        if not isinstance(value, str):
            raise F3411FieldError(message, field, f"expected a str, got {value!r}")
        try:
            raw = value.encode("ascii")
        except UnicodeEncodeError:
            raise F3411FieldError(message, field, f"expected ASCII text, got {value!r}") from None
        if len(raw) > self.size:
            raise F3411FieldError(message, field, f"{len(raw)} characters do not fit {self.c_name}")
        return raw.ljust(self.size, b"\0")

    def to_mavlink(self, value: WireValue) -> object:
        # As pymavlink does: the text ends at the first NUL; non-ASCII bytes become U+FFFD.
        assert isinstance(value, bytes)
        return value.split(b"\0", 1)[0].decode("ascii", errors="replace")


FieldType = IntType | FloatType | BytesType | CharsType

U8 = IntType("uint8_t", 0, 0xFF)
U16 = IntType("uint16_t", 0, 0xFFFF)
I16 = IntType("int16_t", -0x8000, 0x7FFF)
U32 = IntType("uint32_t", 0, 0xFFFF_FFFF)
I32 = IntType("int32_t", -0x8000_0000, 0x7FFF_FFFF)
F32 = FloatType()


# --- MAVLink field lists (common.xml order) ---------------------------------------------------

# Addressing fields of every OPEN_DRONE_ID_* message: not on the F3411 wire, default 0.
LINK_FIELDS: tuple[tuple[str, FieldType], ...] = (
    ("target_system", U8),
    ("target_component", U8),
    ("id_or_mac", BytesType(20)),
)

_OWN_FIELDS: dict[str, tuple[tuple[str, FieldType], ...]] = {
    "OPEN_DRONE_ID_BASIC_ID": (("id_type", U8), ("ua_type", U8), ("uas_id", BytesType(20))),
    "OPEN_DRONE_ID_LOCATION": (
        ("status", U8),
        ("direction", U16),
        ("speed_horizontal", U16),
        ("speed_vertical", I16),
        ("latitude", I32),
        ("longitude", I32),
        ("altitude_barometric", F32),
        ("altitude_geodetic", F32),
        ("height_reference", U8),
        ("height", F32),
        ("horizontal_accuracy", U8),
        ("vertical_accuracy", U8),
        ("barometer_accuracy", U8),
        ("speed_accuracy", U8),
        ("timestamp", F32),
        ("timestamp_accuracy", U8),
    ),
    "OPEN_DRONE_ID_AUTHENTICATION": (
        ("authentication_type", U8),
        ("data_page", U8),
        ("last_page_index", U8),
        ("length", U8),
        ("timestamp", U32),
        ("authentication_data", BytesType(23)),
    ),
    "OPEN_DRONE_ID_SELF_ID": (("description_type", U8), ("description", CharsType(23))),
    "OPEN_DRONE_ID_SYSTEM": (
        ("operator_location_type", U8),
        ("classification_type", U8),
        ("operator_latitude", I32),
        ("operator_longitude", I32),
        ("area_count", U16),
        ("area_radius", U16),
        ("area_ceiling", F32),
        ("area_floor", F32),
        ("category_eu", U8),
        ("class_eu", U8),
        ("operator_altitude_geo", F32),
        ("timestamp", U32),
    ),
    "OPEN_DRONE_ID_OPERATOR_ID": (("operator_id_type", U8), ("operator_id", CharsType(20))),
    "OPEN_DRONE_ID_MESSAGE_PACK": (
        ("single_message_size", U8),
        ("msg_pack_size", U8),
        ("messages", BytesType(225)),
    ),
}

MAVLINK_FIELDS: dict[str, dict[str, FieldType]] = {
    message: dict(LINK_FIELDS + fields) for message, fields in _OWN_FIELDS.items()
}
"""Every field of each OPEN_DRONE_ID_* message, in common.xml order, with its MAVLink type."""


class FieldReader:
    """Checked, typed access to one message's MAVLink field values.

    Every given field is checked against its MAVLink type on construction; unknown fields and
    missing fields (other than those in ``optional``) are errors.
    """

    def __init__(
        self,
        message: str,
        spec: Mapping[str, FieldType],
        values: Mapping[str, object],
        optional: frozenset[str],
    ) -> None:
        self.message = message
        unknown = sorted(set(values) - set(spec))
        if unknown:
            known = ", ".join(spec)
            raise F3411FieldError(message, unknown[0], f"unknown field (known: {known})")
        missing = [name for name in spec if name not in values and name not in optional]
        if missing:
            raise F3411FieldError(message, missing[0], "missing")
        self._values: dict[str, Canonical] = {
            name: spec[name].check(message, name, value) for name, value in values.items()
        }

    def integer(self, name: str) -> int:
        value = self._values[name]
        assert isinstance(value, int), name
        return value

    def real(self, name: str) -> np.float32:
        value = self._values[name]
        assert isinstance(value, np.float32), name
        return value

    def octets(self, name: str) -> bytes:
        value = self._values[name]
        assert isinstance(value, bytes), name
        return value

    def reject(self, field: str | None, problem: str) -> F3411EncodeError:
        """An error (to raise) for a value of this message that the reference rejects."""
        return F3411EncodeError(self.message, field, problem)


def strncpy(raw: bytes) -> bytes:
    """C ``strncpy`` into a buffer of the same size: everything from the first NUL on is 0."""
    text = raw.split(b"\0", 1)[0]
    return text.ljust(len(raw), b"\0")


# --- quantisers -------------------------------------------------------------------------------


def _round_half_away(x: float) -> int:
    """C ``roundf``/``round``: halves go away from zero (Python's ``round`` goes to even)."""
    magnitude = math.floor(abs(x) + 0.5)  # exact in float64 for every value met here
    return magnitude if x >= 0 else -magnitude


def _clamp(value: int, lo: int, hi: int) -> int:
    return max(lo, min(hi, value))


def direction_to_wire(direction_cdeg: int) -> tuple[int, bool]:
    """Direction over ground -> (byte, E/W bit set); 36100 (unknown) becomes (181, True)."""
    whole_deg = _round_half_away(float(_F32(direction_cdeg) / _F32(100)))
    if whole_deg == 360:
        whole_deg = 0
    west_half = whole_deg >= 180
    return _clamp(whole_deg - 180 if west_half else whole_deg, 0, 0xFF), west_half


def direction_from_wire(byte: int, west_half: bool) -> int:
    return (byte + (180 if west_half else 0)) * 100


_SPEED_FINE_MAX = _F32(0xFF) * _F32(0.25)  # 63.75 m/s: the top of the 0.25 m/s scale


def speed_horizontal_to_wire(speed_cm_s: int) -> tuple[int, bool]:
    """Ground speed -> (byte, multiplier bit set): 0.25 m/s steps to 63.75, 0.75 m/s above."""
    speed_m_s = _F32(speed_cm_s) / _F32(100)
    if speed_m_s <= _SPEED_FINE_MAX:
        return _round_half_away(float(speed_m_s / _F32(0.25))), False
    coarse = _round_half_away(float((speed_m_s - _SPEED_FINE_MAX) / _F32(0.75)))
    return _clamp(coarse, 0, 0xFF), True


def speed_horizontal_from_wire(byte: int, multiplier: bool) -> int:
    """Ground speed in cm/s that encodes back to the same byte and multiplier bit.

    That is the byte's nominal speed, except for byte 0 with the multiplier bit: the encoder
    sends speeds just above 63.75 m/s that way, while 63.75 m/s itself goes out as byte 255
    without the bit. The decoder answers 63.76 m/s there, the slowest speed in that cell.
    """
    if not multiplier:
        return byte * 25
    return byte * 75 + 6375 if byte else 6376


def speed_vertical_to_wire(speed_cm_s: int) -> int:
    """Vertical speed (up positive) -> int8 in 0.5 m/s steps, truncated toward zero."""
    return _clamp(int(_F32(speed_cm_s) / _F32(100) / _F32(0.5)), -0x80, 0x7F)


def speed_vertical_from_wire(raw: int) -> int:
    return raw * 50


def lat_lon_to_wire(angle_deg_e7: int) -> int:
    """Latitude or longitude: the reference goes through double degrees and rounds back."""
    return _clamp(_round_half_away(angle_deg_e7 / 1e7 * 1e7), -1_800_000_000, 1_800_000_000)


def altitude_to_wire(altitude_m: np.float32) -> int:
    """Altitude -> uint16 in 0.5 m steps above -1000 m, truncated toward zero."""
    return _clamp(int((_F32(altitude_m) + _F32(1000)) / _F32(0.5)), 0, 0xFFFF)


def altitude_from_wire(raw: int) -> float:
    return raw * 0.5 - 1000.0


TIMESTAMP_UNKNOWN_S = 65535.0
_TIMESTAMP_UNKNOWN_RAW = 0xFFFF


def timestamp_to_wire(timestamp_s: np.float32) -> int:
    """Seconds after the full hour -> tenths of a second, rounded; 65535 s (unknown) -> 0xFFFF."""
    if timestamp_s == TIMESTAMP_UNKNOWN_S:
        return _TIMESTAMP_UNKNOWN_RAW
    return _clamp(_round_half_away(float(_F32(timestamp_s) * _F32(10))), 0, 36000)


def timestamp_from_wire(raw: int) -> float:
    if raw == _TIMESTAMP_UNKNOWN_RAW:
        return TIMESTAMP_UNKNOWN_S
    return float(_F32(raw) / _F32(10))


def area_radius_to_wire(radius_m: int) -> int:
    return _clamp(radius_m // 10, 0, 0xFF)


def area_radius_from_wire(raw: int) -> int:
    return raw * 10
