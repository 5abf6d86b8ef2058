"""ASTM F3411 (Open Drone ID) messages to and from MAVLink ``OPEN_DRONE_ID_*`` field values.

Pure: no I/O, no pymavlink. Field names and units are those of MAVLink common.xml (latitude in
degE7, speeds in cm/s, direction in cdeg, altitudes in m as float32, LOCATION timestamp in s after
the full UTC hour, SYSTEM/AUTHENTICATION timestamps in s since 2019-01-01 UTC); ``uint8_t[n]``
arrays are lists of ints and ``char[n]`` arrays are ``str``. The bytes match the reference C
library (opendroneid-core-c, fed through its MAVLink adapter) byte for byte, and :func:`encode`
rejects exactly what that library rejects. The scalar quantisers and their float32 arithmetic are
in :mod:`ridsafe.common.f3411_fields`.

Every message is 25 bytes, little-endian; byte 0 is ``type << 4 | protocol version`` with
version 2. Bit fields are listed from the most significant bit down.

=====  ===============  ==========================================================================
type   message          bytes 1..24
=====  ===============  ==========================================================================
0x0    BASIC_ID         1: id_type(4) ua_type(4); 2-21: uas_id; 22-24: 0
0x1    LOCATION         1: status(4) 0(1) height_reference(1) E/W(1) speed multiplier(1);
                        2: direction; 3: speed_horizontal; 4: speed_vertical (int8);
                        5-8: latitude (int32); 9-12: longitude (int32);
                        13-14 / 15-16 / 17-18: altitude_barometric / altitude_geodetic / height;
                        19: vertical_accuracy(4) horizontal_accuracy(4);
                        20: barometer_accuracy(4) speed_accuracy(4);
                        21-22: timestamp (0.1 s); 23: 0(4) timestamp_accuracy(4); 24: 0
0x2    AUTHENTICATION   1: authentication_type(4) data_page(4); then page 0:
                        2: last_page_index; 3: length; 4-7: timestamp (uint32);
                        8-24: authentication_data[0:17];  other pages: 2-24: authentication_data
0x3    SELF_ID          1: description_type; 2-24: description
0x4    SYSTEM           1: 0(3) classification_type(3) operator_location_type(2);
                        2-5 / 6-9: operator_latitude / operator_longitude (int32);
                        10-11: area_count; 12: area_radius (10 m); 13-14 / 15-16: area_ceiling /
                        area_floor; 17: category_eu(4) class_eu(4); 18-19: operator_altitude_geo;
                        20-23: timestamp (uint32, s since 2019-01-01 UTC); 24: 0
0x5    OPERATOR_ID      1: operator_id_type; 2-21: operator_id; 22-24: 0
0xF    MESSAGE_PACK     1: single_message_size (25); 2: msg_pack_size N (1..9);
                        3..: N messages of 25 bytes (the pack is 3 + 25 N bytes long)
=====  ===============  ==========================================================================

Altitudes are uint16 in 0.5 m steps above -1000 m. Text and ID fields are NUL-padded (the
reference copies them with ``strncpy``, so text ends at the first NUL; ``uas_id`` of id_type 1
and 2 likewise, other id types are copied verbatim).

Inputs the reference rejects (:class:`F3411EncodeError`): any 4-bit enum (id/ua type, status,
accuracies, authentication type, data page, EU category and class) above 15, height_reference
above 1, operator_location_type above 3, classification_type above 7; direction outside
0..36000 cdeg, horizontal speed outside 0..25425 cm/s, vertical speed outside -6200..6200 cm/s
(the unknown values 36100, 25500 and 6300 pass); latitude beyond +-90 deg, longitude beyond
+-180 deg; any altitude outside -1000..31767.5 m; LOCATION timestamp outside 0..3600 s except
65535 (unknown); area_radius above 2550 m; on authentication page 0, last_page_index above 15 or
a length longer than its pages hold (17 + 23 * last_page_index bytes); a message pack whose
single_message_size is not 25, whose msg_pack_size is outside 1..9, or which holds a pack, an
unknown type, more than 2 BASIC_ID, more than 16 AUTHENTICATION or more than one of any other
message.
"""

from __future__ import annotations

import enum
import struct
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import NamedTuple

from ridsafe.common import f3411_fields as q
from ridsafe.common.f3411_fields import (
    F32,
    F3411DecodeError,
    F3411EncodeError,
    F3411Error,
    F3411FieldError,
    FieldReader,
    FieldType,
    WireValue,
)

__all__ = [
    "MESSAGE_NAMES",
    "MESSAGE_SIZE",
    "PACK_MAX_MESSAGES",
    "PROTOCOL_VERSION",
    "DecodedMessage",
    "F3411DecodeError",
    "F3411EncodeError",
    "F3411Error",
    "F3411FieldError",
    "MessageType",
    "decode",
    "decode_pack",
    "encode",
    "message_type",
    "split_pack",
]

MESSAGE_SIZE = 25
PROTOCOL_VERSION = 2
PACK_MAX_MESSAGES = 9
AUTH_MAX_PAGES = 16
AUTH_PAGE_ZERO_DATA_SIZE = 17
AUTH_PAGE_DATA_SIZE = 23
PACK_HEADER_SIZE = 3


class MessageType(enum.IntEnum):
    """The message type nibble (byte 0, high four bits)."""

    BASIC_ID = 0x0
    LOCATION = 0x1
    AUTHENTICATION = 0x2
    SELF_ID = 0x3
    SYSTEM = 0x4
    OPERATOR_ID = 0x5
    MESSAGE_PACK = 0xF

    @property
    def mavlink_name(self) -> str:
        return f"OPEN_DRONE_ID_{self.name}"


class DecodedMessage(NamedTuple):
    """A decoded message: the MAVLink message name and its field values."""

    message: str
    fields: dict[str, object]


Values = dict[str, WireValue]
"""Decoded wire values before they are shaped into MAVLink Python values."""

# Addressing fields: not on the F3411 wire; optional when encoding, 0 when decoding.
_LINK_NAMES = frozenset(name for name, _ in q.LINK_FIELDS)
_LINK_DEFAULTS: Values = {"target_system": 0, "target_component": 0, "id_or_mac": bytes(20)}


# --- value ranges the reference refuses -------------------------------------------------------


@dataclass(frozen=True)
class _Range:
    """``lo <= value <= hi`` or ``value == unknown``; floats are compared as float32."""

    field: str
    lo: float
    hi: float
    unit: str = ""
    unknown: float | None = None

    def problem(self, value: float) -> str | None:
        if self.lo <= value <= self.hi or value == self.unknown:
            return None
        unit = f" {self.unit}" if self.unit else ""
        allowed = f"{self.lo:.9g}..{self.hi:.9g}{unit}"
        if self.unknown is not None:
            allowed += f" or {self.unknown:.9g} (unknown)"
        return f"{value:.9g}{unit} is outside {allowed}; the reference encoder rejects it"


def _nibbles(*names: str) -> tuple[_Range, ...]:
    return tuple(_Range(name, 0, 15) for name in names)


_ALT_MIN_M, _ALT_MAX_M = -1000.0, 31767.5
_LAT_MAX, _LON_MAX = 900_000_000, 1_800_000_000

_RANGES: dict[MessageType, tuple[_Range, ...]] = {
    MessageType.BASIC_ID: _nibbles("id_type", "ua_type"),
    MessageType.LOCATION: (
        *_nibbles("status", "horizontal_accuracy", "vertical_accuracy", "barometer_accuracy"),
        *_nibbles("speed_accuracy", "timestamp_accuracy"),
        _Range("height_reference", 0, 1),
        _Range("direction", 0, 36000, "cdeg", unknown=36100),
        _Range("speed_horizontal", 0, 25425, "cm/s", unknown=25500),
        _Range("speed_vertical", -6200, 6200, "cm/s", unknown=6300),
        _Range("latitude", -_LAT_MAX, _LAT_MAX, "degE7"),
        _Range("longitude", -_LON_MAX, _LON_MAX, "degE7"),
        *(
            _Range(name, _ALT_MIN_M, _ALT_MAX_M, "m")
            for name in ("altitude_barometric", "altitude_geodetic", "height")
        ),
        _Range("timestamp", 0, 3600, "s", unknown=q.TIMESTAMP_UNKNOWN_S),
    ),
    MessageType.AUTHENTICATION: _nibbles("authentication_type", "data_page"),
    MessageType.SELF_ID: (),
    MessageType.SYSTEM: (
        _Range("operator_location_type", 0, 3),
        _Range("classification_type", 0, 7),
        *_nibbles("category_eu", "class_eu"),
        _Range("operator_latitude", -_LAT_MAX, _LAT_MAX, "degE7"),
        _Range("operator_longitude", -_LON_MAX, _LON_MAX, "degE7"),
        _Range("area_radius", 0, 2550, "m"),
        *(
            _Range(name, _ALT_MIN_M, _ALT_MAX_M, "m")
            for name in ("area_ceiling", "area_floor", "operator_altitude_geo")
        ),
    ),
    MessageType.OPERATOR_ID: (),
    MessageType.MESSAGE_PACK: (),
}


def _check_ranges(kind: MessageType, reader: FieldReader, fields: Mapping[str, FieldType]) -> None:
    for rule in _RANGES[kind]:
        value = reader.real(rule.field) if fields[rule.field] is F32 else reader.integer(rule.field)
        problem = rule.problem(float(value))
        if problem is not None:
            raise reader.reject(rule.field, problem)


# --- per-message layouts ----------------------------------------------------------------------

_BASIC_ID = struct.Struct("<BB20s3x")
_LOCATION = struct.Struct("<BBBBbiiHHHBBHBx")
_AUTH_PAGE_ZERO = struct.Struct("<BBBBI17s")
_AUTH_PAGE = struct.Struct("<BB23s")
_SELF_ID = struct.Struct("<BB23s")
_SYSTEM = struct.Struct("<BBiiHBHHBHIx")
_OPERATOR_ID = struct.Struct("<BB20s3x")
_PACK_HEADER = struct.Struct("<BBB")


def _header(kind: MessageType) -> int:
    return kind << 4 | PROTOCOL_VERSION


def _encode_basic_id(r: FieldReader) -> bytes:
    id_type = r.integer("id_type")
    uas_id = r.octets("uas_id")
    if id_type in (1, 2):  # serial number, CAA registration: text, copied with strncpy
        uas_id = q.strncpy(uas_id)
    flags = id_type << 4 | r.integer("ua_type")
    return _BASIC_ID.pack(_header(MessageType.BASIC_ID), flags, uas_id)


def _decode_basic_id(data: bytes) -> Values:
    _, flags, uas_id = _BASIC_ID.unpack(data)
    return {"id_type": flags >> 4, "ua_type": flags & 0xF, "uas_id": uas_id}


def _encode_location(r: FieldReader) -> bytes:
    direction, west_half = q.direction_to_wire(r.integer("direction"))
    speed, multiplier = q.speed_horizontal_to_wire(r.integer("speed_horizontal"))
    flags = r.integer("status") << 4 | r.integer("height_reference") << 2
    return _LOCATION.pack(
        _header(MessageType.LOCATION),
        flags | west_half << 1 | multiplier,
        direction,
        speed,
        q.speed_vertical_to_wire(r.integer("speed_vertical")),
        q.lat_lon_to_wire(r.integer("latitude")),
        q.lat_lon_to_wire(r.integer("longitude")),
        q.altitude_to_wire(r.real("altitude_barometric")),
        q.altitude_to_wire(r.real("altitude_geodetic")),
        q.altitude_to_wire(r.real("height")),
        r.integer("vertical_accuracy") << 4 | r.integer("horizontal_accuracy"),
        r.integer("barometer_accuracy") << 4 | r.integer("speed_accuracy"),
        q.timestamp_to_wire(r.real("timestamp")),
        r.integer("timestamp_accuracy"),
    )


def _decode_location(data: bytes) -> Values:
    (
        _,
        flags,
        direction,
        speed,
        speed_v,
        lat,
        lon,
        baro,
        geo,
        height,
        acc_vh,
        acc_bs,
        time,
        acc_t,
    ) = _LOCATION.unpack(data)
    return {
        "status": flags >> 4,
        "direction": q.direction_from_wire(direction, bool(flags & 0b10)),
        "speed_horizontal": q.speed_horizontal_from_wire(speed, bool(flags & 0b1)),
        "speed_vertical": q.speed_vertical_from_wire(speed_v),
        "latitude": lat,
        "longitude": lon,
        "altitude_barometric": q.altitude_from_wire(baro),
        "altitude_geodetic": q.altitude_from_wire(geo),
        "height_reference": flags >> 2 & 0b1,
        "height": q.altitude_from_wire(height),
        "horizontal_accuracy": acc_vh & 0xF,
        "vertical_accuracy": acc_vh >> 4,
        "barometer_accuracy": acc_bs >> 4,
        "speed_accuracy": acc_bs & 0xF,
        "timestamp": q.timestamp_from_wire(time),
        "timestamp_accuracy": acc_t & 0xF,
    }


def _encode_authentication(r: FieldReader) -> bytes:
    page = r.integer("data_page")
    header = (_header(MessageType.AUTHENTICATION), r.integer("authentication_type") << 4 | page)
    data = r.octets("authentication_data")
    if page != 0:
        return _AUTH_PAGE.pack(*header, data)
    last_page = r.integer("last_page_index")
    if last_page >= AUTH_MAX_PAGES:
        raise r.reject("last_page_index", f"{last_page} is outside 0..{AUTH_MAX_PAGES - 1}")
    capacity = AUTH_PAGE_ZERO_DATA_SIZE + last_page * AUTH_PAGE_DATA_SIZE
    length = r.integer("length")
    if length > capacity:
        problem = f"{length} bytes do not fit pages 0..{last_page} (at most {capacity} bytes)"
        raise r.reject("length", problem)
    timestamp = r.integer("timestamp")
    return _AUTH_PAGE_ZERO.pack(
        *header, last_page, length, timestamp, data[:AUTH_PAGE_ZERO_DATA_SIZE]
    )


def _decode_authentication(data: bytes) -> Values:
    _, flags, payload = _AUTH_PAGE.unpack(data)
    values: Values = {"authentication_type": flags >> 4, "data_page": flags & 0xF}
    if flags & 0xF:
        values.update(last_page_index=0, length=0, timestamp=0, authentication_data=payload)
        return values
    _, _, last_page, length, timestamp, page_data = _AUTH_PAGE_ZERO.unpack(data)
    values.update(last_page_index=last_page, length=length, timestamp=timestamp)
    values["authentication_data"] = page_data
    return values


def _encode_self_id(r: FieldReader) -> bytes:
    description = q.strncpy(r.octets("description"))
    return _SELF_ID.pack(_header(MessageType.SELF_ID), r.integer("description_type"), description)


def _decode_self_id(data: bytes) -> Values:
    _, description_type, description = _SELF_ID.unpack(data)
    return {"description_type": description_type, "description": description}


def _encode_system(r: FieldReader) -> bytes:
    return _SYSTEM.pack(
        _header(MessageType.SYSTEM),
        r.integer("classification_type") << 2 | r.integer("operator_location_type"),
        q.lat_lon_to_wire(r.integer("operator_latitude")),
        q.lat_lon_to_wire(r.integer("operator_longitude")),
        r.integer("area_count"),
        q.area_radius_to_wire(r.integer("area_radius")),
        q.altitude_to_wire(r.real("area_ceiling")),
        q.altitude_to_wire(r.real("area_floor")),
        r.integer("category_eu") << 4 | r.integer("class_eu"),
        q.altitude_to_wire(r.real("operator_altitude_geo")),
        r.integer("timestamp"),
    )


def _decode_system(data: bytes) -> Values:
    (_, flags, lat, lon, count, radius, ceiling, floor, eu, altitude, timestamp) = _SYSTEM.unpack(
        data
    )
    return {
        "operator_location_type": flags & 0b11,
        "classification_type": flags >> 2 & 0b111,
        "operator_latitude": lat,
        "operator_longitude": lon,
        "area_count": count,
        "area_radius": q.area_radius_from_wire(radius),
        "area_ceiling": q.altitude_from_wire(ceiling),
        "area_floor": q.altitude_from_wire(floor),
        "category_eu": eu >> 4,
        "class_eu": eu & 0xF,
        "operator_altitude_geo": q.altitude_from_wire(altitude),
        "timestamp": timestamp,
    }


def _encode_operator_id(r: FieldReader) -> bytes:
    operator_id = q.strncpy(r.octets("operator_id"))
    kind = r.integer("operator_id_type")
    return _OPERATOR_ID.pack(_header(MessageType.OPERATOR_ID), kind, operator_id)


def _decode_operator_id(data: bytes) -> Values:
    _, operator_id_type, operator_id = _OPERATOR_ID.unpack(data)
    return {"operator_id_type": operator_id_type, "operator_id": operator_id}


# At most this many of each type in a pack (as the reference allows); others are refused.
_PACK_LIMITS: dict[MessageType, int] = {
    MessageType.BASIC_ID: 2,
    MessageType.LOCATION: 1,
    MessageType.AUTHENTICATION: AUTH_MAX_PAGES,
    MessageType.SELF_ID: 1,
    MessageType.SYSTEM: 1,
    MessageType.OPERATOR_ID: 1,
}


def _pack_problem(single_size: int, count: int, body: bytes) -> tuple[str, str] | None:
    """(field, problem) if the reference refuses this pack, else None; ``body`` = N messages."""
    if single_size != MESSAGE_SIZE:
        return "single_message_size", f"is {single_size}, must be {MESSAGE_SIZE}"
    if not 1 <= count <= PACK_MAX_MESSAGES:
        return "msg_pack_size", f"is {count}, must be 1..{PACK_MAX_MESSAGES}"
    nibbles = [body[i * MESSAGE_SIZE] >> 4 for i in range(count)]
    for index, nibble in enumerate(nibbles):
        if nibble not in _PACK_LIMITS:
            return "messages", f"message {index} has type 0x{nibble:X}, not allowed in a pack"
    for kind, seen in Counter(MessageType(n) for n in nibbles).items():
        if seen > _PACK_LIMITS[kind]:
            limit = _PACK_LIMITS[kind]
            return "messages", f"holds {seen} {kind.name} messages, at most {limit} allowed"
    return None


def _encode_message_pack(r: FieldReader) -> bytes:
    single_size, count = r.integer("single_message_size"), r.integer("msg_pack_size")
    body = r.octets("messages")[: count * MESSAGE_SIZE]
    problem = _pack_problem(single_size, count, body)
    if problem is not None:
        raise r.reject(*problem)
    return _PACK_HEADER.pack(_header(MessageType.MESSAGE_PACK), single_size, count) + body


def _decode_message_pack(data: bytes) -> Values:
    _, single_size, count = _PACK_HEADER.unpack_from(data)
    body = data[PACK_HEADER_SIZE:]
    if len(data) != PACK_HEADER_SIZE + count * single_size:
        raise F3411DecodeError(
            f"message pack of {count} x {single_size} bytes must be"
            f" {PACK_HEADER_SIZE + count * single_size} bytes long, got {len(data)}"
        )
    problem = _pack_problem(single_size, count, body)
    if problem is not None:
        raise F3411DecodeError(f"malformed message pack: {problem[0]} {problem[1]}")
    return {"single_message_size": single_size, "msg_pack_size": count, "messages": body}


# --- the table --------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Codec:
    kind: MessageType
    encode: Callable[[FieldReader], bytes]
    decode: Callable[[bytes], Values]

    @property
    def fields(self) -> dict[str, FieldType]:
        return q.MAVLINK_FIELDS[self.kind.mavlink_name]


_CODECS: dict[MessageType, _Codec] = {
    codec.kind: codec
    for codec in (
        _Codec(MessageType.BASIC_ID, _encode_basic_id, _decode_basic_id),
        _Codec(MessageType.LOCATION, _encode_location, _decode_location),
        _Codec(MessageType.AUTHENTICATION, _encode_authentication, _decode_authentication),
        _Codec(MessageType.SELF_ID, _encode_self_id, _decode_self_id),
        _Codec(MessageType.SYSTEM, _encode_system, _decode_system),
        _Codec(MessageType.OPERATOR_ID, _encode_operator_id, _decode_operator_id),
        _Codec(MessageType.MESSAGE_PACK, _encode_message_pack, _decode_message_pack),
    )
}
_BY_NAME: dict[str, _Codec] = {codec.kind.mavlink_name: codec for codec in _CODECS.values()}

MESSAGE_NAMES: tuple[str, ...] = tuple(_BY_NAME)
"""The MAVLink messages this codec handles, e.g. ``"OPEN_DRONE_ID_LOCATION"``."""


# --- public API -------------------------------------------------------------------------------


def encode(message_name: str, fields: Mapping[str, object]) -> bytes:
    """F3411 bytes of one MAVLink ``OPEN_DRONE_ID_*`` message given as field values.

    Returns 25 bytes (3 + 25 N for a message pack, whose ``messages`` hold encoded messages).
    target_system, target_component and id_or_mac may be left out; every other field is needed.
    Raises :class:`F3411FieldError` for a value that is no value of its MAVLink field, and
    :class:`F3411EncodeError` for values the reference encoder rejects.
    """
    codec = _BY_NAME.get(message_name)
    if codec is None:
        raise F3411EncodeError(
            message_name, None, f"unknown message (known: {', '.join(MESSAGE_NAMES)})"
        )
    spec = codec.fields
    reader = FieldReader(message_name, spec, fields, optional=_LINK_NAMES)
    _check_ranges(codec.kind, reader, spec)
    return codec.encode(reader)


def message_type(data: bytes) -> MessageType:
    """The type of an F3411 message; raises :class:`F3411DecodeError` if the header is bad."""
    if not data:
        raise F3411DecodeError("empty message")
    nibble, version = data[0] >> 4, data[0] & 0xF
    if nibble not in _CODECS:
        raise F3411DecodeError(f"unknown message type 0x{nibble:X} (byte 0 = 0x{data[0]:02X})")
    if version != PROTOCOL_VERSION:
        raise F3411DecodeError(f"protocol version {version}, only {PROTOCOL_VERSION} is handled")
    return MessageType(nibble)


def decode(data: bytes) -> DecodedMessage:
    """MAVLink message name and field values of one F3411 message (or message pack).

    Fields not on the wire come back as 0 (target_system, target_component, id_or_mac, and on
    authentication pages other than 0 last_page_index, length and timestamp); arrays are padded
    to their MAVLink size. Each quantised value is one that encodes back to the same bytes, so
    ``encode(*decode(b)) == b`` for everything :func:`encode` produces. Raises
    :class:`F3411DecodeError` on malformed input; values are not range-checked.
    """
    data = bytes(data)
    kind = message_type(data)
    if kind is not MessageType.MESSAGE_PACK and len(data) != MESSAGE_SIZE:
        raise F3411DecodeError(f"{kind.name} must be {MESSAGE_SIZE} bytes, got {len(data)}")
    if kind is MessageType.MESSAGE_PACK and len(data) < PACK_HEADER_SIZE:
        raise F3411DecodeError(f"message pack shorter than its {PACK_HEADER_SIZE}-byte header")
    codec = _CODECS[kind]
    values = {**_LINK_DEFAULTS, **codec.decode(data)}
    fields = {name: spec.to_mavlink(values[name]) for name, spec in codec.fields.items()}
    return DecodedMessage(kind.mavlink_name, fields)


def split_pack(data: bytes) -> list[bytes]:
    """The 25-byte messages inside a message pack (checked as :func:`decode` checks it)."""
    message = decode(data).message
    if message != MessageType.MESSAGE_PACK.mavlink_name:
        raise F3411DecodeError(f"expected a message pack, got {message}")
    body = bytes(data)[PACK_HEADER_SIZE:]
    return [body[i : i + MESSAGE_SIZE] for i in range(0, len(body), MESSAGE_SIZE)]


def pack(messages: Sequence[bytes]) -> bytes:
    """A message pack of encoded 25-byte messages (refused as :func:`encode` refuses it)."""
    body = b"".join(messages)
    fields = {"single_message_size": MESSAGE_SIZE, "msg_pack_size": len(messages), "messages": body}
    return encode(MessageType.MESSAGE_PACK.mavlink_name, fields)


def decode_pack(data: bytes) -> list[DecodedMessage]:
    """Every message inside a message pack, decoded."""
    return [decode(message) for message in split_pack(data)]
