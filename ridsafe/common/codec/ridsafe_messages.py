"""The ridsafe dialect's own messages (ids 61000-61099): domain message <-> MAVLink fields.

RIDSAFE_RID_FRAME carries a heard F3411 frame whole (bytes, RSSI, sender, transport) from a
RID transponder to its companion; RIDSAFE_OBSERVATION goes up to the GCS; RIDSAFE_UNSAFE_REGION
and RIDSAFE_SPOOF_ALERT come down; the LOCKSTEP pair paces a lockstep run over UDP.
"""

from __future__ import annotations

import math
import re
import struct
from collections.abc import Sequence
from types import SimpleNamespace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ridsafe.common import messages as m
from ridsafe.common.codec import observation_kernels
from ridsafe.common.codec.inbound import first_invalid_field
from ridsafe.common.codec.units import (
    DEG_E7,
    ODID_ID_LEN,
    ODID_UNKNOWN_DIRECTION_CDEG,
    ODID_UNKNOWN_SPEED_H_CMS,
    ODID_UNKNOWN_SPEED_V_CMS,
    CodecTable,
    Wire,
    check_finite,
    check_lat_lon,
    cms,
    deg_e7,
    id20,
    saturating_round,
    text,
    uas_id_bytes,
    us,
    wire,
)
from ridsafe.common.dialect import ridsafe_v20 as mav
from ridsafe.common.errors import WireError

#: The longest frame RIDSAFE_RID_FRAME carries: a message pack of 9 (3 + 9 x 25 bytes).
RID_FRAME_MAX_BYTES = 228


def _rid_frame_to(msg: m.RidFrameReport) -> Wire:
    frame = msg.frame
    if not 0 < len(frame) <= RID_FRAME_MAX_BYTES:
        raise WireError(f"RID frame of {len(frame)} bytes, expected 1..{RID_FRAME_MAX_BYTES}")
    if len(msg.sender_id) > ODID_ID_LEN:
        raise WireError(f"sender id is {len(msg.sender_id)} bytes, at most {ODID_ID_LEN} fit")
    return wire(
        mav.MAVLink_ridsafe_rid_frame_message,
        msg.rssi_dbm,
        id20(msg.sender_id),
        msg.transport,
        msg.channel,
        len(frame),
        frame.ljust(RID_FRAME_MAX_BYTES, b"\x00"),  # bytes: packed whole (wire_struct)
    )


def _rid_frame_from(raw: Any) -> m.RidFrameReport:
    check_finite("RIDSAFE_RID_FRAME", raw.rssi_dbm)
    if not 0 < raw.frame_len <= RID_FRAME_MAX_BYTES:
        raise WireError(f"RIDSAFE_RID_FRAME: frame_len {raw.frame_len}")
    sender = bytes(raw.id_or_mac).rstrip(b"\x00")
    frame = bytes(raw.frame[: raw.frame_len])
    return m.RidFrameReport(frame, raw.rssi_dbm, sender, raw.transport, raw.channel)


def _observation_to(msg: m.Observation) -> Wire:
    """A report's fields; a course or speed that is None or not finite goes as unknown."""
    course = _finite_or_none(msg.claimed_course_deg)
    speed_h = _finite_or_none(msg.claimed_speed_horizontal_m_s)
    speed_v = _finite_or_none(msg.claimed_speed_vertical_m_s)
    speed_h_cms = None if speed_h is None else min(25425, saturating_round(speed_h * 100.0))
    return wire(
        mav.MAVLink_ridsafe_observation_message,
        us(msg.t_s),
        deg_e7(msg.rx_lat_deg),
        deg_e7(msg.rx_lon_deg),
        msg.rx_alt_m,
        deg_e7(msg.claimed_lat_deg),
        deg_e7(msg.claimed_lon_deg),
        msg.claimed_alt_m,
        msg.rid_timestamp_s,
        msg.rssi_dbm,
        ODID_UNKNOWN_DIRECTION_CDEG if course is None else round(course * 100.0) % 36000,
        ODID_UNKNOWN_SPEED_H_CMS if speed_h is None else speed_h_cms,
        ODID_UNKNOWN_SPEED_V_CMS if speed_v is None else cms(speed_v),
        uas_id_bytes(msg.uas_id),
    )


def _finite_or_none(value: float | None) -> float | None:
    return value if value is not None and math.isfinite(value) else None


def _observation_from(raw: Any) -> m.Observation:
    rx_lat, rx_lon = raw.rx_lat / DEG_E7, raw.rx_lon / DEG_E7
    c_lat, c_lon = raw.claimed_lat / DEG_E7, raw.claimed_lon / DEG_E7
    check_lat_lon(rx_lat, rx_lon, "RIDSAFE_OBSERVATION receiver")
    check_lat_lon(c_lat, c_lon, "RIDSAFE_OBSERVATION claimed")
    check_finite(
        "RIDSAFE_OBSERVATION", raw.rx_alt, raw.claimed_alt, raw.rid_timestamp, raw.rssi_dbm
    )
    return m.Observation(
        t_s=raw.time_usec / 1e6,
        rx_lat_deg=rx_lat,
        rx_lon_deg=rx_lon,
        rx_alt_m=raw.rx_alt,
        claimed_lat_deg=c_lat,
        claimed_lon_deg=c_lon,
        claimed_alt_m=raw.claimed_alt,
        rid_timestamp_s=raw.rid_timestamp,
        rssi_dbm=raw.rssi_dbm,
        claimed_course_deg=None if raw.claimed_direction > 35999 else raw.claimed_direction / 100,
        claimed_speed_horizontal_m_s=None
        if raw.claimed_speed_horizontal == ODID_UNKNOWN_SPEED_H_CMS
        else raw.claimed_speed_horizontal / 100.0,
        claimed_speed_vertical_m_s=None
        if raw.claimed_speed_vertical == ODID_UNKNOWN_SPEED_V_CMS
        else raw.claimed_speed_vertical / 100.0,
        uas_id=text(raw.uas_id),
    )


def _check_record_offsets(cls: Any, offsets: dict[str, int], stride: int) -> None:
    """A compiled decoding's field offsets are the message's wire layout (raises if not)."""
    offset = 0
    for name, (count, code) in zip(
        cls.ordered_fieldnames,
        re.findall(r"(\d*)([a-zA-Z?])", cls.unpacker.format[1:]),
        strict=True,
    ):
        if offsets[name] != offset:
            raise AssertionError(
                f"{cls.msgname}.{name} at byte {offset}, the kernel reads it elsewhere"
            )
        offset += struct.calcsize(f"<{count}{code}")
    if offset > stride:
        raise AssertionError(f"{cls.msgname}: {offset} bytes, more than the kernel's stride")


_OBSERVATION = mav.MAVLink_ridsafe_observation_message
_PACK = mav.MAVLink_ridsafe_observation_pack_message
_check_record_offsets(_OBSERVATION, observation_kernels.OFFSETS, observation_kernels.RECORD_STRIDE)
_check_record_offsets(_PACK, observation_kernels.PACK_OFFSETS, observation_kernels.PACK_STRIDE)
# The pack's fields are the single report's, each an array, then ``count`` and the ids: its
# encoding and decoding below take them in that order.
if _PACK.fieldnames != [*_OBSERVATION.fieldnames[:-1], "count", "uas_id"]:
    raise AssertionError(f"{_PACK.msgname}: fields {_PACK.fieldnames}, not the report's + count")
_ID_OFFSET = observation_kernels.OFFSETS["uas_id"]
_PACK_COUNT = observation_kernels.PACK_OFFSETS["count"]
_PACK_IDS = observation_kernels.PACK_OFFSETS["uas_id"]
#: Reports one RIDSAFE_OBSERVATION_PACK carries at most.
OBSERVATIONS_PER_PACK = observation_kernels.PACK_SIZE
#: Claimed ids as sent (NUL padding dropped or not) -> their text, for the rows' decodings.
_ID_TEXT: dict[bytes, str] = {}
_ID_TEXT_SIZE = 4096


def observation_rows(payloads: Sequence[bytes]) -> m.ObservationRows | None:
    """RIDSAFE_OBSERVATION payloads (as framed: trailing zeros trimmed) decoded together,
    each row what ``_observation_from`` makes of its payload; None when any payload is one
    ``_observation_from`` refuses (a latitude or longitude out of range, a non-finite
    value): the caller then decodes them one by one, which says which and why."""
    size = _OBSERVATION.unpacker.size
    values = np.empty((len(payloads), len(m.OBSERVATION_COLUMNS)))
    if not observation_kernels.decode_observations(
        _joined(payloads, size, observation_kernels.RECORD_STRIDE), values
    ):
        return None
    values.setflags(write=False)
    return m.ObservationRows(values, tuple(_id_text(p[_ID_OFFSET:size]) for p in payloads))


def observation_pack_rows(payloads: Sequence[bytes]) -> m.ObservationRows | None:
    """RIDSAFE_OBSERVATION_PACK payloads decoded together, their reports in order, each row
    what ``_observation_pack_from`` makes of it; None when a pack is one it refuses (a count
    outside 1-3, a report ``_observation_from`` refuses)."""
    counts = [p[_PACK_COUNT] if len(p) > _PACK_COUNT else 0 for p in payloads]
    if not all(1 <= count <= OBSERVATIONS_PER_PACK for count in counts):
        return None
    size = _PACK.unpacker.size
    values = np.empty((sum(counts), len(m.OBSERVATION_COLUMNS)))
    if not observation_kernels.decode_observation_packs(
        _joined(payloads, size, observation_kernels.PACK_STRIDE),
        np.array(counts, dtype=np.int64),
        values,
    ):
        return None
    values.setflags(write=False)
    ids = tuple(
        _id_text(p[_PACK_IDS + 20 * k : _PACK_IDS + 20 * (k + 1)])
        for p, count in zip(payloads, counts, strict=True)
        for k in range(count)
    )
    return m.ObservationRows(values, ids)


def _joined(payloads: Sequence[bytes], size: int, stride: int) -> NDArray[np.uint8]:
    """The payloads (trailing zeros restored) one after another, each padded to ``stride``."""
    return np.frombuffer(
        bytearray(b"".join(p[:size].ljust(stride, b"\x00") for p in payloads)), np.uint8
    )


def _id_text(sent: bytes) -> str:
    known = _ID_TEXT.get(sent)
    if known is None:
        if len(_ID_TEXT) >= _ID_TEXT_SIZE:
            _ID_TEXT.clear()
        known = _ID_TEXT[sent] = text(sent)
    return known


#: An unused entry of a pack: every field zero, no id.
_UNUSED_ROW = (0,) * 12 + (b"",)


def _observation_pack_to(msg: m.ObservationPack) -> Wire:
    """The pack's reports as RIDSAFE_OBSERVATION encodes each (``_observation_to``), field by
    field into the arrays; unused entries zero."""
    n = len(msg.observations)
    if not 1 <= n <= OBSERVATIONS_PER_PACK:
        raise WireError(f"an observation pack holds 1 to {OBSERVATIONS_PER_PACK}, not {n}")
    rows = [_observation_to(o).args for o in msg.observations]
    rows += [_UNUSED_ROW] * (OBSERVATIONS_PER_PACK - n)
    *columns, ids = zip(*rows, strict=True)  # per field, its three values
    return wire(_PACK, *columns, n, b"".join(uas.ljust(ODID_ID_LEN, b"\x00") for uas in ids))


#: Claimed ids -> their bytes as a pack carries them (NUL padded), for the batch encoding.
_ID_BYTES: dict[str, bytes] = {}


def observation_rows_payloads(rows: m.ObservationRows) -> list[bytes] | None:
    """A companion's batch of reports (some 60 to 130 a second) as the payloads of the
    RIDSAFE_OBSERVATION_PACKs that carry them three to a pack, in order, encoded together:
    each the bytes ``_observation_pack_to`` gives its ``ObservationPack`` (``pack_rows``).
    None when a report does not fit its fields: the caller then sends the packs one by one,
    which says which and why. No report, no pack."""
    n, per_pack = len(rows), OBSERVATIONS_PER_PACK
    counts = [per_pack] * (n // per_pack) + ([n % per_pack] if n % per_pack else [])
    return _packs_payloads(rows, counts) if counts else []


def pack_rows(rows: m.ObservationRows) -> list[m.ObservationPack]:
    """The ``ObservationPack`` messages ``rows`` goes as, three reports to a pack, in order."""
    per_pack = OBSERVATIONS_PER_PACK
    reports = rows.observations()
    return [
        m.ObservationPack(tuple(reports[i : i + per_pack]))
        for i in range(0, len(reports), per_pack)
    ]


def _packs_payloads(rows: m.ObservationRows, counts: list[int]) -> list[bytes] | None:
    """Payloads of the packs holding ``counts[0]`` of ``rows``, then ``counts[1]``... (each
    1-3, summing to the rows)."""
    try:
        ids = b"".join([_ID_BYTES.get(uas) or _id_bytes(uas) for uas in rows.uas_id])
    except (WireError, UnicodeEncodeError):
        return None
    stride = observation_kernels.PACK_STRIDE
    buf = np.zeros(len(counts) * stride, dtype=np.uint8)
    if not observation_kernels.encode_observation_packs(
        rows.values, np.frombuffer(ids, np.uint8), np.array(counts, dtype=np.int64), buf
    ):
        return None
    raw, size = buf.tobytes(), _PACK.unpacker.size
    return [raw[i : i + size].rstrip(b"\x00") or raw[i : i + 1] for i in range(0, len(raw), stride)]


def _id_bytes(uas_id: str) -> bytes:
    padded = uas_id_bytes(uas_id).ljust(ODID_ID_LEN, b"\x00")
    if len(_ID_BYTES) >= _ID_TEXT_SIZE:
        _ID_BYTES.clear()
    _ID_BYTES[uas_id] = padded
    return padded


def _observation_pack_from(raw: Any) -> m.ObservationRows:
    """Each report of the pack as ``_observation_from`` decodes it, held to the edge's rules
    (``inbound.first_invalid_field``): one report that breaks them refuses the whole pack."""
    count = raw.count
    if not 1 <= count <= OBSERVATIONS_PER_PACK:
        raise WireError(f"RIDSAFE_OBSERVATION_PACK: count {count}")
    ids = bytes(raw.uas_id)
    reports = []
    for k in range(count):
        fields = {name: getattr(raw, name)[k] for name in _PACK.fieldnames[:-2]}
        fields["uas_id"] = ids[ODID_ID_LEN * k : ODID_ID_LEN * (k + 1)]
        report = _observation_from(SimpleNamespace(**fields))
        bad_field = first_invalid_field(report)
        if bad_field is not None:
            raise WireError(f"RIDSAFE_OBSERVATION_PACK: report {k}: {bad_field} out of range")
        reports.append(report)
    return m.ObservationRows.of(reports)


def _region_to(msg: m.UnsafeRegionMsg) -> Wire:
    return wire(
        mav.MAVLink_ridsafe_unsafe_region_message,
        us(msg.t_s),
        us(msg.valid_until_s),
        deg_e7(msg.center_lat_deg),
        deg_e7(msg.center_lon_deg),
        msg.center_alt_m,
        list(msg.cov_ned_m2),
        list(msg.v_ned_m_s),
        msg.chi2_threshold,
        msg.alpha,
        msg.track_id,
        msg.flags,
        uas_id_bytes(msg.uas_id),
    )


def _region_from(raw: Any) -> m.UnsafeRegionMsg:
    lat, lon = raw.center_lat / DEG_E7, raw.center_lon / DEG_E7
    check_lat_lon(lat, lon, "RIDSAFE_UNSAFE_REGION")
    cov = tuple(float(c) for c in raw.cov_ned)
    vel = tuple(float(v) for v in raw.vel_ned)
    check_finite("RIDSAFE_UNSAFE_REGION", raw.center_alt, raw.chi2_threshold, *cov, *vel)
    return m.UnsafeRegionMsg(
        raw.time_usec / 1e6,
        raw.valid_until_usec / 1e6,
        lat,
        lon,
        raw.center_alt,
        (cov[0], cov[1], cov[2], cov[3], cov[4], cov[5]),
        (vel[0], vel[1], vel[2]),
        raw.chi2_threshold,
        raw.alpha,
        raw.track_id,
        raw.flags,
        text(raw.uas_id),
    )


def _alert_to(msg: m.SpoofAlert) -> Wire:
    return wire(
        mav.MAVLink_ridsafe_spoof_alert_message,
        us(msg.t_s),
        msg.statistic,
        msg.threshold,
        msg.detector,
        msg.state,
        uas_id_bytes(msg.uas_id),
    )


def _alert_from(raw: Any) -> m.SpoofAlert:
    return m.SpoofAlert(
        raw.time_usec / 1e6,
        raw.statistic,
        raw.threshold,
        raw.detector,
        raw.state,
        text(raw.uas_id),
    )


def _tick_to(msg: m.LockstepTick) -> Wire:
    return wire(mav.MAVLink_ridsafe_lockstep_tick_message, us(msg.t_s), msg.tick)


def _tick_from(raw: Any) -> m.LockstepTick:
    return m.LockstepTick(raw.time_usec / 1e6, raw.tick)


def _done_to(msg: m.LockstepDone) -> Wire:
    return wire(mav.MAVLink_ridsafe_lockstep_done_message, us(msg.t_s), msg.tick)


def _done_from(raw: Any) -> m.LockstepDone:
    return m.LockstepDone(raw.time_usec / 1e6, raw.tick)


CODECS: CodecTable = {
    m.RidFrameReport: ("RIDSAFE_RID_FRAME", _rid_frame_to, _rid_frame_from),
    m.Observation: ("RIDSAFE_OBSERVATION", _observation_to, _observation_from),
    m.ObservationPack: (
        "RIDSAFE_OBSERVATION_PACK",
        _observation_pack_to,
        _observation_pack_from,
    ),
    m.UnsafeRegionMsg: ("RIDSAFE_UNSAFE_REGION", _region_to, _region_from),
    m.SpoofAlert: ("RIDSAFE_SPOOF_ALERT", _alert_to, _alert_from),
    m.LockstepTick: ("RIDSAFE_LOCKSTEP_TICK", _tick_to, _tick_from),
    m.LockstepDone: ("RIDSAFE_LOCKSTEP_DONE", _done_to, _done_from),
}

#: Messages with a columnar decoding (``MavlinkLink(columnar=True)``), by name.
ROW_DECODERS = {
    "RIDSAFE_OBSERVATION": observation_rows,
    "RIDSAFE_OBSERVATION_PACK": observation_pack_rows,
}
