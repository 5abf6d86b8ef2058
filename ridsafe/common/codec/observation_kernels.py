"""RIDSAFE_OBSERVATION and RIDSAFE_OBSERVATION_PACK payloads decoded many at a time, compiled
(``ridsafe_messages.observation_rows``, ``observation_pack_rows``): a GCS takes some 4,000
reports a second at 64 aircraft; and a companion's packs encoded a batch at a time
(``ridsafe_messages.observation_rows_payloads``, ``encode_observation_packs``).

The payloads come joined, each zero-padded to its message's stride (``RECORD_STRIDE``,
``PACK_STRIDE``) so that every field sits at an offset its size divides: the kernels read
them through typed views of the one buffer. The offsets are the messages' wire layouts
(``ridsafe_messages`` checks them against the dialect at import); each value is converted
exactly as ``_observation_from`` converts it (``_convert``, shared by both).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.jit import jit, jit_inline

#: A RIDSAFE_OBSERVATION payload's 66 bytes padded to a multiple of 8.
RECORD_STRIDE = 72
#: Byte offsets of its fields (the struct ``<QiifiifffHHh20s``).
OFFSETS = {
    "time_usec": 0,
    "rx_lat": 8,
    "rx_lon": 12,
    "rx_alt": 16,
    "claimed_lat": 20,
    "claimed_lon": 24,
    "claimed_alt": 28,
    "rid_timestamp": 32,
    "rssi_dbm": 36,
    "claimed_direction": 40,
    "claimed_speed_horizontal": 42,
    "claimed_speed_vertical": 44,
    "uas_id": 46,
}
#: A RIDSAFE_OBSERVATION_PACK payload's 199 bytes padded to a multiple of 8.
PACK_STRIDE = 200
#: Reports one pack carries at most: each field is an array of this many.
PACK_SIZE = 3
#: Byte offsets of its fields (the struct ``<3Q3i3i3f3i3i3f3f3f3H3H3hB60B``): the first
#: element of each array; element k lies k x the element's size further.
PACK_OFFSETS = {
    "time_usec": 0,
    "rx_lat": 24,
    "rx_lon": 36,
    "rx_alt": 48,
    "claimed_lat": 60,
    "claimed_lon": 72,
    "claimed_alt": 84,
    "rid_timestamp": 96,
    "rssi_dbm": 108,
    "claimed_direction": 120,
    "claimed_speed_horizontal": 126,
    "claimed_speed_vertical": 132,
    "count": 138,
    "uas_id": 139,
}
_UNKNOWN_DIRECTION_ABOVE = 35999  # cdeg; ``_observation_from``'s None
_UNKNOWN_DIRECTION_CDEG = 36100
_UNKNOWN_SPEED_H_CMS = 25500
_UNKNOWN_SPEED_V_CMS = 6300
_MAX_SPEED_H_CMS = 25425
#: A claimed id's bytes on the wire (NUL padded).
ID_LEN = 20
_PACK_COUNT = PACK_OFFSETS["count"]
_PACK_IDS = PACK_OFFSETS["uas_id"]


@jit_inline
def _convert(
    out: NDArray[np.float64],
    r: int,
    time_usec: np.uint64,
    lats_lons: tuple[np.int32, np.int32, np.int32, np.int32],
    floats: tuple[np.float32, np.float32, np.float32, np.float32],
    speeds: tuple[np.int64, np.int64, np.int64],
) -> bool:
    """Row ``r`` of ``out`` from one report's wire values (``floats``: receiver altitude,
    claimed altitude, RID timestamp, RSSI; ``speeds``: course, ground and vertical speed);
    False when ``_observation_from`` refuses them (a
    latitude or longitude out of range, a non-finite float)."""
    rx_lat, rx_lon, claimed_lat, claimed_lon = lats_lons
    rx_alt, claimed_alt, rid_timestamp, rssi = floats
    direction, speed_h, speed_v = speeds
    out[r, 0] = time_usec / 1e6
    out[r, 1] = rx_lat / 1e7
    out[r, 2] = rx_lon / 1e7
    out[r, 3] = rx_alt
    out[r, 4] = claimed_lat / 1e7
    out[r, 5] = claimed_lon / 1e7
    out[r, 6] = claimed_alt
    out[r, 7] = rid_timestamp
    out[r, 8] = rssi
    out[r, 9] = np.nan if direction > _UNKNOWN_DIRECTION_ABOVE else direction / 100
    out[r, 10] = np.nan if speed_h == _UNKNOWN_SPEED_H_CMS else speed_h / 100.0
    out[r, 11] = np.nan if speed_v == _UNKNOWN_SPEED_V_CMS else speed_v / 100.0
    return bool(
        abs(out[r, 1]) <= 90.0
        and abs(out[r, 2]) <= 180.0
        and abs(out[r, 4]) <= 90.0
        and abs(out[r, 5]) <= 180.0
        and np.isfinite(out[r, 3])
        and np.isfinite(out[r, 6])
        and np.isfinite(out[r, 7])
        and np.isfinite(out[r, 8])
    )


@jit
def decode_observations(buf: NDArray[np.uint8], out: NDArray[np.float64]) -> bool:
    """Fill ``out`` (one row per RIDSAFE_OBSERVATION payload, ``messages.
    OBSERVATION_COLUMNS``) from ``buf``; False when a payload is one ``_observation_from``
    refuses."""
    u64, i32, f32 = buf.view(np.uint64), buf.view(np.int32), buf.view(np.float32)
    u16, i16 = buf.view(np.uint16), buf.view(np.int16)
    ok = True
    for r in range(out.shape[0]):
        base = r * RECORD_STRIDE
        w4, w2 = base // 4, base // 2
        lats_lons = (i32[w4 + 2], i32[w4 + 3], i32[w4 + 5], i32[w4 + 6])
        floats = (f32[w4 + 4], f32[w4 + 7], f32[w4 + 8], f32[w4 + 9])
        speeds = (np.int64(u16[w2 + 20]), np.int64(u16[w2 + 21]), np.int64(i16[w2 + 22]))
        if not _convert(out, r, u64[base // 8], lats_lons, floats, speeds):
            ok = False
    return ok


@jit
def decode_observation_packs(
    buf: NDArray[np.uint8], counts: NDArray[np.int64], out: NDArray[np.float64]
) -> bool:
    """Fill ``out`` (the first ``counts[p]`` reports of each RIDSAFE_OBSERVATION_PACK payload
    p, in order) from ``buf``; False when a report is one ``_observation_from`` refuses."""
    u64, i32, f32 = buf.view(np.uint64), buf.view(np.int32), buf.view(np.float32)
    u16, i16 = buf.view(np.uint16), buf.view(np.int16)
    ok, r = True, 0
    for p in range(counts.shape[0]):
        base = p * PACK_STRIDE
        w4, w2 = base // 4, base // 2
        for k in range(counts[p]):
            lats_lons = (i32[w4 + 6 + k], i32[w4 + 9 + k], i32[w4 + 15 + k], i32[w4 + 18 + k])
            floats = (f32[w4 + 12 + k], f32[w4 + 21 + k], f32[w4 + 24 + k], f32[w4 + 27 + k])
            speeds = (
                np.int64(u16[w2 + 60 + k]),
                np.int64(u16[w2 + 63 + k]),
                np.int64(i16[w2 + 66 + k]),
            )
            if not _convert(out, r, u64[base // 8 + k], lats_lons, floats, speeds):
                ok = False
            r += 1
    return ok


@jit_inline
def _fits_f32(value: float) -> bool:
    """``struct``'s ``f`` packs it: a finite value whose float32 is not infinite, or a
    non-finite one."""
    return not (np.isinf(np.float32(value)) and not np.isinf(value))


@jit_inline
def _course_and_speeds(row: NDArray[np.float64]) -> tuple[bool, int, int, int]:
    """(they fit, course cdeg, ground speed cm/s, vertical speed cm/s) as ``_observation_to``
    encodes a report's last three columns: unknown where NaN or infinite."""
    course, speed_h, speed_v = (
        np.rint(row[9] * 100.0),
        np.rint(row[10] * 100.0),
        np.rint(row[11] * 100.0),
    )
    course_cdeg, speed_h_cms, speed_v_cms = (
        _UNKNOWN_DIRECTION_CDEG,
        _UNKNOWN_SPEED_H_CMS,
        _UNKNOWN_SPEED_V_CMS,
    )
    # Unknown where the value (not its hundredths) is not finite, as in ``_observation_to``:
    # a finite speed beyond its field saturates, a course of any size wraps (``fmod`` of an
    # integer-valued float is exact, as Python's ``%`` of the int ``round`` gives).
    if np.isfinite(row[9]):
        if not np.isfinite(course):
            return False, 0, 0, 0  # hundredths past float's range: ``round`` raises
        wrapped = np.fmod(course, 36000.0)
        course_cdeg = int(wrapped + 36000.0 if wrapped < 0.0 else wrapped)
    if np.isfinite(row[10]):
        if speed_h < 0.0:  # a uint16
            return False, 0, 0, 0
        speed_h_cms = int(min(speed_h, _MAX_SPEED_H_CMS))
    if np.isfinite(row[11]):
        speed_v_cms = int(max(-32768.0, min(32767.0, speed_v)))
    return True, course_cdeg, speed_h_cms, speed_v_cms


@jit
def encode_observation_packs(
    values: NDArray[np.float64],
    ids: NDArray[np.uint8],
    counts: NDArray[np.int64],
    out: NDArray[np.uint8],
) -> bool:
    """Fill ``out`` (zeros, ``PACK_STRIDE`` bytes per pack) with the RIDSAFE_OBSERVATION_PACK
    payloads of the reports ``values`` (one row each, ``messages.OBSERVATION_COLUMNS``, NaN
    for an unknown course or speed) with the claimed ids ``ids`` (``ID_LEN`` bytes a row),
    ``counts[p]`` of them in pack p, each value converted as ``_observation_to`` converts it
    (Python's ``round`` is half to even, as ``np.rint``). False when a value does not fit
    its field, where ``struct`` would refuse it (``out`` is then partly written)."""
    u64, i32, f32 = out.view(np.uint64), out.view(np.int32), out.view(np.float32)
    u16, i16 = out.view(np.uint16), out.view(np.int16)
    r = 0
    for p in range(counts.shape[0]):
        base = p * PACK_STRIDE
        w4, w2 = base // 4, base // 2
        out[base + _PACK_COUNT] = counts[p]
        for k in range(counts[p]):
            row = values[r]
            t_us = np.rint(row[0] * 1e6)
            if not (np.isfinite(t_us) and t_us < 2.0**64):
                return False
            u64[base // 8 + k] = np.uint64(max(t_us, 0.0))
            for word, column in ((6, 1), (9, 2), (15, 4), (18, 5)):  # latitudes, longitudes
                e7 = np.rint(row[column] * 1e7)
                if not -(2.0**31) <= e7 < 2.0**31:
                    return False
                i32[w4 + word + k] = np.int32(e7)
            for word, column in ((12, 3), (21, 6), (24, 7), (27, 8)):  # altitudes, time, RSSI
                if not _fits_f32(row[column]):
                    return False
                f32[w4 + word + k] = np.float32(row[column])
            fits, course_cdeg, speed_h_cms, speed_v_cms = _course_and_speeds(row)
            if not fits:
                return False
            u16[w2 + 60 + k], u16[w2 + 63 + k], i16[w2 + 66 + k] = (
                course_cdeg,
                speed_h_cms,
                speed_v_cms,
            )
            first_id = base + _PACK_IDS + ID_LEN * k
            out[first_id : first_id + ID_LEN] = ids[ID_LEN * r : ID_LEN * (r + 1)]
            r += 1
    return True
