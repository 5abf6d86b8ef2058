"""Tests of the ASTM F3411 codec (ridsafe.common.f3411).

Three oracles: the reference encoder's 3,000 vectors (differential), encodings derived by hand
from the rules in the module docstring, and round-trip properties (decode(encode(x)) equals x up
to the wire's quantisation; encode(decode(b)) == b).
"""

from __future__ import annotations

import gzip
import json
import math
import re
import struct
import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ridsafe.common import f3411
from ridsafe.common.errors import RidsafeError, WireError
from ridsafe.common.f3411 import (
    F3411DecodeError,
    F3411EncodeError,
    F3411FieldError,
    MessageType,
    decode,
    decode_pack,
    encode,
    split_pack,
)
from ridsafe.common.f3411_fields import MAVLINK_FIELDS, IntType, strncpy

VECTORS_PATH = Path(__file__).parents[1] / "data" / "odid_f3411_vectors.jsonl.gz"
PROPERTY_SETTINGS = settings(max_examples=250)

Fields = dict[str, Any]


@pytest.fixture(scope="module")
def vectors() -> list[dict[str, Any]]:
    with gzip.open(VECTORS_PATH, "rt", encoding="utf-8") as lines:
        return [json.loads(line) for line in lines]


def _encode_or_none(message: str, fields: Mapping[str, object]) -> str | None:
    try:
        return encode(message, fields).hex()
    except F3411EncodeError:
        return None


# --- the reference vectors --------------------------------------------------------------------


def test_vectors_cover_every_message_with_acceptances_and_rejections(
    vectors: list[dict[str, Any]],
) -> None:
    assert len(vectors) == 3000
    accepted = {case["message"] for case in vectors if case["f3411_hex"] is not None}
    rejected = {case["message"] for case in vectors if case["f3411_hex"] is None}
    assert accepted == set(f3411.MESSAGE_NAMES)
    assert {"OPEN_DRONE_ID_LOCATION", "OPEN_DRONE_ID_MESSAGE_PACK"} <= rejected


def test_every_reference_vector_is_reproduced_byte_for_byte(vectors: list[dict[str, Any]]) -> None:
    mismatches = []
    for line, case in enumerate(vectors, start=1):
        got = _encode_or_none(case["message"], case["fields"])
        if got != case["f3411_hex"]:
            mismatches.append(
                f"line {line} {case['message']}: got {got}, expected {case['f3411_hex']}"
            )
    assert not mismatches, f"{len(mismatches)} mismatches:\n" + "\n".join(mismatches[:20])


def test_decode_then_encode_gives_back_every_accepted_vector(
    vectors: list[dict[str, Any]],
) -> None:
    mismatches = []
    for line, case in enumerate(vectors, start=1):
        if case["f3411_hex"] is None:
            continue
        wire = bytes.fromhex(case["f3411_hex"])
        message, fields = decode(wire)
        if message != case["message"] or encode(message, fields) != wire:
            mismatches.append(f"line {line}: {message} {fields}")
    assert not mismatches, f"{len(mismatches)} mismatches:\n" + "\n".join(mismatches[:20])


def test_rejected_vectors_raise_an_error_that_names_a_field(
    vectors: list[dict[str, Any]],
) -> None:
    for case in vectors:
        if case["f3411_hex"] is None:
            with pytest.raises(F3411EncodeError) as caught:
                encode(case["message"], case["fields"])
            assert not isinstance(caught.value, F3411FieldError)
            assert caught.value.field in MAVLINK_FIELDS[case["message"]]
            assert caught.value.message_name == case["message"]


# --- the MAVLink side --------------------------------------------------------------------------


def test_field_lists_match_mavlink_common_xml() -> None:
    pymavlink = pytest.importorskip("pymavlink")
    xml_path = Path(pymavlink.__file__).parent / "dialects" / "v20" / "common.xml"
    if not xml_path.exists():
        pytest.skip(f"{xml_path} not installed")
    declared = {
        message.get("name"): {
            field.get("name"): field.get("type") for field in message.iter("field")
        }
        for message in ET.parse(xml_path).iter("message")
    }
    for name, fields in MAVLINK_FIELDS.items():
        ours = {field: spec.c_name for field, spec in fields.items()}
        assert list(ours.items()) == list(declared[name].items()), name


# --- hand-derived encodings -------------------------------------------------------------------

LINK = {"target_system": 0, "target_component": 0, "id_or_mac": [0] * 20}

HAND_LOCATION: Fields = {
    "status": 2,  # airborne
    "direction": 18050,  # 180.5 deg: roundf -> 181 (half away from zero) -> E/W bit, 1
    "speed_horizontal": 1000,  # 10 m/s / 0.25 -> 40, multiplier bit 0
    "speed_vertical": -75,  # -0.75 m/s / 0.5 = -1.5 -> truncated toward zero: -1
    "latitude": 473977418,
    "longitude": -1223315000,
    "altitude_barometric": 99.75,  # (1099.75) / 0.5 = 2199.5 -> truncated: 2199
    "altitude_geodetic": -1000.0,  # unknown -> 0
    "height_reference": 1,  # over ground
    "height": 31767.5,  # top of the scale -> 65535
    "horizontal_accuracy": 10,
    "vertical_accuracy": 4,
    "barometer_accuracy": 3,
    "speed_accuracy": 2,
    "timestamp": 0.25,  # 2.5 tenths -> roundf -> 3 (Python's round would give 2)
    "timestamp_accuracy": 7,
}


def test_location_by_hand() -> None:
    expected = struct.pack(
        "<BBBBbiiHHHBBHBB",
        0x12,  # type 1, protocol version 2
        2 << 4 | 1 << 2 | 1 << 1 | 0,  # status, height_reference, E/W, multiplier
        1,
        40,
        -1,
        473977418,
        -1223315000,
        2199,
        0,
        65535,
        4 << 4 | 10,
        3 << 4 | 2,
        3,
        7,
        0,
    )
    assert encode("OPEN_DRONE_ID_LOCATION", LINK | HAND_LOCATION) == expected


@pytest.mark.parametrize(
    ("speed_cm_s", "byte", "multiplier", "decoded_cm_s"),
    [
        (6375, 255, 0, 6375),  # 63.75 m/s: top of the fine scale
        # Just above it: coarse scale, (0.01 / 0.75) rounds to 0. That cell holds 63.75 < v <
        # 64.125 m/s, so it decodes to 63.76 m/s (63.75 m/s would encode as byte 255).
        (6376, 0, 1, 6376),
        (6413, 1, 1, 6450),  # 0.38 / 0.75 = 0.507 -> 1 -> 63.75 + 0.75
        (25425, 254, 1, 25425),  # the largest speed MAVLink asks for
        (25500, 255, 1, 25500),  # unknown
    ],
)
def test_horizontal_speed_scales_by_hand(
    speed_cm_s: int, byte: int, multiplier: int, decoded_cm_s: int
) -> None:
    wire = encode("OPEN_DRONE_ID_LOCATION", HAND_LOCATION | {"speed_horizontal": speed_cm_s})
    assert (wire[3], wire[1] & 1) == (byte, multiplier)
    decoded = decode(wire).fields
    assert decoded["speed_horizontal"] == decoded_cm_s
    assert encode("OPEN_DRONE_ID_LOCATION", decoded) == wire


@pytest.mark.parametrize(
    ("direction_cdeg", "byte", "west_half"),
    [
        (0, 0, 0),
        (17949, 179, 0),
        (17950, 0, 1),  # 179.5 -> 180: E/W bit, 0
        (35949, 179, 1),
        (35950, 0, 0),  # 359.5 -> 360, which the reference folds to 0
        (36000, 0, 0),
        (36100, 181, 1),  # unknown: 361 deg
    ],
)
def test_direction_by_hand(direction_cdeg: int, byte: int, west_half: int) -> None:
    wire = encode("OPEN_DRONE_ID_LOCATION", HAND_LOCATION | {"direction": direction_cdeg})
    assert (wire[2], wire[1] >> 1 & 1) == (byte, west_half)


def test_float32_arithmetic_decides_the_rounding() -> None:
    # The float32 nearest 0.45 is 0.44999998807...; times 10 in float64 that is 4.4999998... (-> 4)
    # but in float32 it rounds to exactly 4.5, which roundf takes away from zero: 5.
    timestamp_s = float(np.float32(0.45))
    assert timestamp_s * 10 < 4.5
    # Likewise the float32 just below 0.5 m plus 1000 rounds up to 1000.5 m: 2001, not 2000.
    altitude_m = float(np.nextafter(np.float32(0.5), np.float32(0)))
    fields = HAND_LOCATION | {"timestamp": timestamp_s, "altitude_barometric": altitude_m}
    wire = encode("OPEN_DRONE_ID_LOCATION", fields)
    assert struct.unpack_from("<H", wire, 21)[0] == 5
    assert struct.unpack_from("<H", wire, 13)[0] == 2001


def test_unknown_timestamp_is_sent_as_0xffff() -> None:
    wire = encode("OPEN_DRONE_ID_LOCATION", HAND_LOCATION | {"timestamp": 65535.0})
    assert wire[21:23] == b"\xff\xff"
    assert decode(wire).fields["timestamp"] == 65535.0


def test_basic_id_copies_text_ids_up_to_the_first_nul_and_others_verbatim() -> None:
    uas_id = list(b"SN123\0XYZ") + [0] * 11
    serial = encode("OPEN_DRONE_ID_BASIC_ID", {"id_type": 1, "ua_type": 2, "uas_id": uas_id})
    assert serial == bytes([0x02, 1 << 4 | 2]) + b"SN123".ljust(20, b"\0") + bytes(3)
    session = encode("OPEN_DRONE_ID_BASIC_ID", {"id_type": 4, "ua_type": 2, "uas_id": uas_id})
    assert session[2:22] == bytes(uas_id)


def test_authentication_page_zero_and_later_pages_by_hand() -> None:
    data = list(range(1, 24))
    page_zero: Fields = {"authentication_type": 2, "data_page": 0, "last_page_index": 1}
    page_zero |= {"length": 40, "timestamp": 0x01020304, "authentication_data": data}
    expected_zero = bytes([0x22, 2 << 4 | 0, 1, 40, 4, 3, 2, 1]) + bytes(range(1, 18))
    assert encode("OPEN_DRONE_ID_AUTHENTICATION", page_zero) == expected_zero
    page_one = page_zero | {"data_page": 1}
    assert encode("OPEN_DRONE_ID_AUTHENTICATION", page_one) == bytes([0x22, 0x21, *data])
    decoded = decode(expected_zero).fields
    assert decoded["authentication_data"] == [*range(1, 18), 0, 0, 0, 0, 0, 0]


def test_system_by_hand() -> None:
    fields = {
        "operator_location_type": 1,
        "classification_type": 1,
        "operator_latitude": -337000000,
        "operator_longitude": 1512000000,
        "area_count": 3,
        "area_radius": 259,  # 10 m steps, integer division: 25
        "area_ceiling": 120.0,
        "area_floor": -1000.0,
        "category_eu": 1,
        "class_eu": 2,
        "operator_altitude_geo": 12.3,
        "timestamp": 200_000_000,  # s since 2019-01-01, sent as it comes
    }
    expected = struct.pack(
        "<BBiiHBHHBHIB",
        0x42,
        1 << 2 | 1,
        -337000000,
        1512000000,
        3,
        25,
        2240,
        0,
        1 << 4 | 2,
        2024,  # (12.3 + 1000) / 0.5 = 2024.6 -> 2024
        200_000_000,
        0,
    )
    assert encode("OPEN_DRONE_ID_SYSTEM", fields) == expected


def test_text_messages_by_hand() -> None:
    self_id = encode("OPEN_DRONE_ID_SELF_ID", {"description_type": 0, "description": "Survey"})
    assert self_id == b"\x32\x00" + b"Survey".ljust(23, b"\0")
    operator = encode("OPEN_DRONE_ID_OPERATOR_ID", {"operator_id_type": 0, "operator_id": "FIN87"})
    assert operator == b"\x52\x00" + b"FIN87".ljust(20, b"\0") + bytes(3)


def test_message_pack_by_hand() -> None:
    basic = encode("OPEN_DRONE_ID_BASIC_ID", {"id_type": 1, "ua_type": 2, "uas_id": list(b"A1")})
    location = encode("OPEN_DRONE_ID_LOCATION", HAND_LOCATION)
    fields = {"single_message_size": 25, "msg_pack_size": 2, "messages": list(basic + location)}
    wire = encode("OPEN_DRONE_ID_MESSAGE_PACK", fields)
    assert wire == bytes([0xF2, 25, 2]) + basic + location
    assert split_pack(wire) == [basic, location]
    assert [message for message, _ in decode_pack(wire)] == [
        "OPEN_DRONE_ID_BASIC_ID",
        "OPEN_DRONE_ID_LOCATION",
    ]
    assert decode(wire).fields["messages"] == list(basic + location) + [0] * 175


# --- rejections and input errors --------------------------------------------------------------


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"direction": 36050}, "direction"),
        ({"speed_horizontal": 25426}, "speed_horizontal"),
        ({"speed_vertical": -6201}, "speed_vertical"),
        ({"speed_vertical": 6250}, "speed_vertical"),
        ({"latitude": 900000001}, "latitude"),
        ({"longitude": -1800000001}, "longitude"),
        ({"height": -1000.5}, "height"),
        ({"altitude_geodetic": 31768.0}, "altitude_geodetic"),
        ({"timestamp": 3600.5}, "timestamp"),
        ({"timestamp": -0.5}, "timestamp"),
        ({"height_reference": 2}, "height_reference"),
        ({"status": 16}, "status"),
    ],
)
def test_location_values_the_reference_rejects(change: Fields, field: str) -> None:
    with pytest.raises(F3411EncodeError) as caught:
        encode("OPEN_DRONE_ID_LOCATION", HAND_LOCATION | change)
    assert caught.value.field == field
    assert "outside" in str(caught.value)


def test_authentication_length_must_fit_the_pages() -> None:
    fields: Fields = {
        "authentication_type": 1,
        "data_page": 0,
        "last_page_index": 1,
        "timestamp": 0,
    }
    fields["authentication_data"] = [0] * 23
    assert encode("OPEN_DRONE_ID_AUTHENTICATION", fields | {"length": 40})  # 17 + 23 = 40
    with pytest.raises(F3411EncodeError, match="length"):
        encode("OPEN_DRONE_ID_AUTHENTICATION", fields | {"length": 41})
    with pytest.raises(F3411EncodeError, match="last_page_index"):
        encode("OPEN_DRONE_ID_AUTHENTICATION", fields | {"last_page_index": 16, "length": 0})
    # Pages other than 0 carry neither length nor page count: neither is checked.
    assert encode("OPEN_DRONE_ID_AUTHENTICATION", fields | {"data_page": 3, "length": 255})


def _pack_of(*messages: bytes, count: int | None = None, size: int = 25) -> Fields:
    body = b"".join(messages)
    return {
        "single_message_size": size,
        "msg_pack_size": len(messages) if count is None else count,
        "messages": list(body.ljust(225, b"\0")),
    }


def test_message_packs_the_reference_rejects() -> None:
    location = encode("OPEN_DRONE_ID_LOCATION", HAND_LOCATION)
    basic = encode("OPEN_DRONE_ID_BASIC_ID", {"id_type": 0, "ua_type": 0, "uas_id": []})
    pack = encode("OPEN_DRONE_ID_MESSAGE_PACK", _pack_of(location))
    assert encode("OPEN_DRONE_ID_MESSAGE_PACK", _pack_of(basic, basic, location))
    cases = {
        "single_message_size": _pack_of(location, size=24),
        "msg_pack_size": _pack_of(location, count=0),
        "messages": _pack_of(location, location),
    }
    cases["messages[basic x3]"] = _pack_of(basic, basic, basic)
    cases["messages[pack]"] = _pack_of(pack[:25])
    cases["messages[type 6]"] = _pack_of(b"\x62" + bytes(24))
    for name, fields in cases.items():
        with pytest.raises(F3411EncodeError) as caught:
            encode("OPEN_DRONE_ID_MESSAGE_PACK", fields)
        assert caught.value.field == name.split("[")[0], name


@pytest.mark.parametrize(
    ("message", "fields", "field", "words"),
    [
        ("OPEN_DRONE_ID_NOPE", {}, None, "unknown message"),
        ("OPEN_DRONE_ID_SELF_ID", {"description_type": 0}, "description", "missing"),
        (
            "OPEN_DRONE_ID_SELF_ID",
            {"description_type": 0, "description": "", "x": 1},
            "x",
            "unknown",
        ),
        ("OPEN_DRONE_ID_SELF_ID", {"description_type": 256, "description": ""}, None, "uint8_t"),
        ("OPEN_DRONE_ID_SELF_ID", {"description_type": True, "description": ""}, None, "uint8_t"),
        ("OPEN_DRONE_ID_SELF_ID", {"description_type": "0", "description": ""}, None, "uint8_t"),
        ("OPEN_DRONE_ID_SELF_ID", {"description_type": 0, "description": "é"}, None, "ASCII"),
        (
            "OPEN_DRONE_ID_SELF_ID",
            {"description_type": 0, "description": "x" * 24},
            None,
            "char[23]",
        ),
        ("OPEN_DRONE_ID_BASIC_ID", {"id_type": 0, "ua_type": 0, "uas_id": [0] * 21}, None, "[20]"),
        (
            "OPEN_DRONE_ID_BASIC_ID",
            {"id_type": 0, "ua_type": 0, "uas_id": [256]},
            "uas_id[0]",
            "256",
        ),
        ("OPEN_DRONE_ID_BASIC_ID", {"id_type": 0, "ua_type": 0, "uas_id": "A1"}, None, "list"),
        (
            "OPEN_DRONE_ID_BASIC_ID",
            {"id_type": 0, "ua_type": 0, "uas_id": [65, True]},
            "uas_id[1]",
            "True",
        ),
        (
            "OPEN_DRONE_ID_BASIC_ID",
            {"id_type": 0, "ua_type": 0, "uas_id": [65, -1]},
            "uas_id[1]",
            "-1",
        ),
    ],
)
def test_field_values_that_are_no_mavlink_values(
    message: str, fields: Fields, field: str | None, words: str
) -> None:
    with pytest.raises(F3411EncodeError, match=re.escape(words)) as caught:
        encode(message, fields)
    if field is not None:
        assert caught.value.field == field
    assert isinstance(caught.value, RidsafeError)


@pytest.mark.parametrize("bad", [math.nan, math.inf, 1e39, "1.0", None])
def test_float_fields_must_be_finite_float32_numbers(bad: object) -> None:
    with pytest.raises(F3411FieldError, match="height"):
        encode("OPEN_DRONE_ID_LOCATION", HAND_LOCATION | {"height": bad})


# --- decode errors -----------------------------------------------------------------------------

GOOD_LOCATION = encode("OPEN_DRONE_ID_LOCATION", HAND_LOCATION)


@pytest.mark.parametrize(
    ("data", "words"),
    [
        (b"", "empty"),
        (GOOD_LOCATION[:24], "25 bytes"),
        (GOOD_LOCATION + b"\0", "25 bytes"),
        (b"\x62" + bytes(24), "unknown message type 0x6"),
        (b"\x11" + GOOD_LOCATION[1:], "protocol version 1"),
        (b"\xf2\x19", "header"),
        (bytes([0xF2, 25, 2]) + GOOD_LOCATION, "53 bytes"),
        (bytes([0xF2, 25, 0]), "msg_pack_size"),
        (bytes([0xF2, 24, 1]) + GOOD_LOCATION[:24], "single_message_size"),
        (bytes([0xF2, 25, 2]) + GOOD_LOCATION * 2, "LOCATION"),
        (bytes([0xF2, 25, 1, 0xF2, 25, 1]) + bytes(22), "type 0xF"),
    ],
)
def test_decode_rejects_malformed_bytes(data: bytes, words: str) -> None:
    with pytest.raises(F3411DecodeError, match=words) as caught:
        decode(data)
    assert isinstance(caught.value, WireError)


def test_split_pack_wants_a_pack_and_decode_pack_checks_each_message() -> None:
    with pytest.raises(F3411DecodeError, match="message pack"):
        split_pack(GOOD_LOCATION)
    old_version = b"\x11" + GOOD_LOCATION[1:]
    pack = encode("OPEN_DRONE_ID_MESSAGE_PACK", _pack_of(old_version))  # the pack sees types only
    with pytest.raises(F3411DecodeError, match="protocol version 1"):
        decode_pack(pack)


@PROPERTY_SETTINGS
@given(st.binary(min_size=25, max_size=25))
def test_decode_of_any_25_bytes_answers_or_raises_a_decode_error(data: bytes) -> None:
    try:
        message, fields = decode(data)
    except F3411DecodeError:
        return
    assert message == MessageType(data[0] >> 4).mavlink_name
    assert set(fields) == set(MAVLINK_FIELDS[message])


# --- round-trip properties ---------------------------------------------------------------------


def _float32s(lo: float, hi: float) -> st.SearchStrategy[float]:
    return st.floats(lo, hi, width=32)


NIBBLE = st.integers(0, 15)
ALTITUDE = _float32s(-1000.0, 31767.5)
LATITUDE = st.integers(-900_000_000, 900_000_000)
LONGITUDE = st.integers(-1_800_000_000, 1_800_000_000)
TEXT = st.characters(min_codepoint=0x20, max_codepoint=0x7E)

LOCATIONS = st.fixed_dictionaries(
    {
        "status": NIBBLE,
        "direction": st.integers(0, 36000) | st.just(36100),
        "speed_horizontal": st.integers(0, 25425) | st.just(25500),
        "speed_vertical": st.integers(-6200, 6200) | st.just(6300),
        "latitude": LATITUDE,
        "longitude": LONGITUDE,
        "altitude_barometric": ALTITUDE,
        "altitude_geodetic": ALTITUDE,
        "height_reference": st.integers(0, 1),
        "height": ALTITUDE,
        "horizontal_accuracy": NIBBLE,
        "vertical_accuracy": NIBBLE,
        "barometer_accuracy": NIBBLE,
        "speed_accuracy": NIBBLE,
        "timestamp": _float32s(0.0, 3600.0) | st.just(65535.0),
        "timestamp_accuracy": NIBBLE,
    }
)
BASIC_IDS = st.fixed_dictionaries(
    {
        "id_type": NIBBLE,
        "ua_type": NIBBLE,
        "uas_id": st.lists(st.integers(0, 255), min_size=20, max_size=20),
    }
)


@st.composite
def authentications(draw: st.DrawFn) -> Fields:
    last_page = draw(st.integers(0, 15))
    return {
        "authentication_type": draw(NIBBLE),
        "data_page": draw(st.integers(0, 15)),
        "last_page_index": last_page,
        "length": draw(st.integers(0, min(255, 17 + 23 * last_page))),
        "timestamp": draw(st.integers(0, 2**32 - 1)),
        "authentication_data": draw(st.lists(st.integers(0, 255), min_size=23, max_size=23)),
    }


SELF_IDS = st.fixed_dictionaries(
    {"description_type": st.integers(0, 255), "description": st.text(TEXT, max_size=23)}
)
OPERATOR_IDS = st.fixed_dictionaries(
    {"operator_id_type": st.integers(0, 255), "operator_id": st.text(TEXT, max_size=20)}
)
SYSTEMS = st.fixed_dictionaries(
    {
        "operator_location_type": st.integers(0, 3),
        "classification_type": st.integers(0, 7),
        "operator_latitude": LATITUDE,
        "operator_longitude": LONGITUDE,
        "area_count": st.integers(0, 0xFFFF),
        "area_radius": st.integers(0, 2550),
        "area_ceiling": ALTITUDE,
        "area_floor": ALTITUDE,
        "category_eu": NIBBLE,
        "class_eu": NIBBLE,
        "operator_altitude_geo": ALTITUDE,
        "timestamp": st.integers(0, 2**32 - 1),
    }
)


def _round_trip(message: str, fields: Fields) -> Fields:
    wire = encode(message, fields)
    assert len(wire) == f3411.MESSAGE_SIZE
    name, decoded = decode(wire)
    assert name == message
    assert encode(name, decoded) == wire  # the decoded value lies in the same quantisation cell
    assert decoded["target_system"] == 0 and decoded["id_or_mac"] == [0] * 20
    return decoded


def _assert_altitude_close(sent: float, got: object) -> None:
    # Truncated to 0.5 m steps; float32 rounding of (alt + 1000) may land up to 2^-9 m above.
    assert isinstance(got, float)
    assert -(2**-8) <= sent - got < 0.5, (sent, got)


def _assert_same(sent: Fields, got: Fields, names: list[str]) -> None:
    for name in names:
        assert got[name] == sent[name], name


@PROPERTY_SETTINGS
@given(LOCATIONS)
def test_location_round_trip(fields: Fields) -> None:
    got = _round_trip("OPEN_DRONE_ID_LOCATION", fields)
    exact = ["status", "latitude", "longitude", "height_reference", "horizontal_accuracy"]
    _assert_same(fields, got, [*exact, "vertical_accuracy", "barometer_accuracy"])
    _assert_same(fields, got, ["speed_accuracy", "timestamp_accuracy"])
    direction_error = abs(fields["direction"] - got["direction"])
    assert min(direction_error, 36000 - direction_error) <= 50  # whole degrees, 360 == 0
    speed, speed_error = (
        fields["speed_horizontal"],
        abs(fields["speed_horizontal"] - got["speed_horizontal"]),
    )
    assert speed_error <= (12.5 if speed <= 6375 else 37.5)  # rounded to 0.25 / 0.75 m/s
    climb, climb_got = fields["speed_vertical"], got["speed_vertical"]
    assert abs(climb_got) <= abs(climb) and abs(climb - climb_got) < 50  # truncated, 0.5 m/s
    for name in ("altitude_barometric", "altitude_geodetic", "height"):
        _assert_altitude_close(fields[name], got[name])
    assert abs(fields["timestamp"] - got["timestamp"]) <= 0.05 + 1e-3  # rounded, 0.1 s


@PROPERTY_SETTINGS
@given(BASIC_IDS)
def test_basic_id_round_trip(fields: Fields) -> None:
    got = _round_trip("OPEN_DRONE_ID_BASIC_ID", fields)
    _assert_same(fields, got, ["id_type", "ua_type"])
    sent = bytes(fields["uas_id"])
    assert got["uas_id"] == list(strncpy(sent) if fields["id_type"] in (1, 2) else sent)


@PROPERTY_SETTINGS
@given(authentications())
def test_authentication_round_trip(fields: Fields) -> None:
    got = _round_trip("OPEN_DRONE_ID_AUTHENTICATION", fields)
    _assert_same(fields, got, ["authentication_type", "data_page"])
    if fields["data_page"] == 0:
        _assert_same(fields, got, ["last_page_index", "length", "timestamp"])
        assert got["authentication_data"] == fields["authentication_data"][:17] + [0] * 6
    else:  # only page 0 carries these
        assert (got["last_page_index"], got["length"], got["timestamp"]) == (0, 0, 0)
        assert got["authentication_data"] == fields["authentication_data"]


@PROPERTY_SETTINGS
@given(SELF_IDS)
def test_self_id_round_trip(fields: Fields) -> None:
    _assert_same(fields, _round_trip("OPEN_DRONE_ID_SELF_ID", fields), list(fields))


@PROPERTY_SETTINGS
@given(OPERATOR_IDS)
def test_operator_id_round_trip(fields: Fields) -> None:
    _assert_same(fields, _round_trip("OPEN_DRONE_ID_OPERATOR_ID", fields), list(fields))


@PROPERTY_SETTINGS
@given(SYSTEMS)
def test_system_round_trip(fields: Fields) -> None:
    got = _round_trip("OPEN_DRONE_ID_SYSTEM", fields)
    exact = ["operator_location_type", "classification_type", "operator_latitude"]
    _assert_same(fields, got, [*exact, "operator_longitude", "area_count", "category_eu"])
    _assert_same(fields, got, ["class_eu", "timestamp"])
    assert 0 <= fields["area_radius"] - got["area_radius"] < 10  # truncated to 10 m
    for name in ("area_ceiling", "area_floor", "operator_altitude_geo"):
        _assert_altitude_close(fields[name], got[name])


PACKABLE: list[tuple[str, st.SearchStrategy[Fields]]] = [
    ("OPEN_DRONE_ID_BASIC_ID", BASIC_IDS),
    ("OPEN_DRONE_ID_LOCATION", LOCATIONS),
    ("OPEN_DRONE_ID_AUTHENTICATION", authentications()),
    ("OPEN_DRONE_ID_SELF_ID", SELF_IDS),
    ("OPEN_DRONE_ID_SYSTEM", SYSTEMS),
    ("OPEN_DRONE_ID_OPERATOR_ID", OPERATOR_IDS),
]


@st.composite
def packs(draw: st.DrawFn) -> list[bytes]:
    """1..9 encoded messages within the pack's limits (<= 2 BASIC_ID, <= 1 of the others)."""
    kinds = draw(st.lists(st.sampled_from(range(len(PACKABLE))), min_size=1, max_size=9))
    kinds = [k for i, k in enumerate(kinds) if k == 2 or kinds[:i].count(k) < (2 if k == 0 else 1)]
    return [encode(PACKABLE[k][0], draw(PACKABLE[k][1])) for k in kinds]


@PROPERTY_SETTINGS
@given(packs())
def test_message_pack_round_trip(messages: list[bytes]) -> None:
    fields = _pack_of(*messages)
    wire = encode("OPEN_DRONE_ID_MESSAGE_PACK", fields)
    assert len(wire) == 3 + 25 * len(messages)
    name, got = decode(wire)
    assert name == "OPEN_DRONE_ID_MESSAGE_PACK"
    _assert_same(fields, got, list(fields))
    assert split_pack(wire) == messages
    assert decode_pack(wire) == [decode(message) for message in messages]


ANY_LOCATION = st.fixed_dictionaries(
    {
        name: st.integers(spec.lo, spec.hi)
        if isinstance(spec, IntType)
        else st.floats(width=32, allow_nan=False, allow_infinity=False)
        for name, spec in MAVLINK_FIELDS["OPEN_DRONE_ID_LOCATION"].items()
        if name not in ("target_system", "target_component", "id_or_mac")
    }
)


@PROPERTY_SETTINGS
@given(ANY_LOCATION)
def test_any_mavlink_location_encodes_or_is_rejected_by_range(fields: Fields) -> None:
    rules: dict[str, Callable[[Any], bool]] = {
        "direction": lambda v: 0 <= v <= 36000 or v == 36100,
        "speed_horizontal": lambda v: v <= 25425 or v == 25500,
        "speed_vertical": lambda v: -6200 <= v <= 6200 or v == 6300,
        "latitude": lambda v: abs(v) <= 900_000_000,
        "timestamp": lambda v: 0 <= v <= 3600 or v == 65535,
        "height_reference": lambda v: v <= 1,
    }
    altitudes = ("altitude_barometric", "altitude_geodetic", "height")
    nibbles = [n for n in fields if n.endswith("accuracy") or n == "status"]
    accepted = all(rule(fields[name]) for name, rule in rules.items())
    accepted &= all(-1000 <= fields[n] <= 31767.5 for n in altitudes)
    accepted &= all(fields[n] <= 15 for n in nibbles)
    assert (_encode_or_none("OPEN_DRONE_ID_LOCATION", fields) is not None) == accepted
