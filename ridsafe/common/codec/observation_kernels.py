"""RIDSAFE_OBSERVATION payloads decoded many at a time, compiled (``ridsafe_messages.
observation_rows``): a GCS takes some 4,000 a second at 64 aircraft.

The payloads come joined, each zero-padded to ``RECORD_STRIDE`` bytes so that every field
sits at an offset its size divides: the kernel reads them through typed views of the one
buffer. The offsets are the message's wire layout (``ridsafe_messages`` checks them against
the dialect at import); each value is converted exactly as ``_observation_from`` converts it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.jit import jit

#: A payload's 66 bytes padded to a multiple of 8.
RECORD_STRIDE = 72
#: Byte offsets of the fields in a payload (the struct ``<QiifiifffHHh20s``).
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
_UNKNOWN_DIRECTION_ABOVE = 35999  # cdeg; ``_observation_from``'s None
_UNKNOWN_SPEED_H_CMS = 25500
_UNKNOWN_SPEED_V_CMS = 6300


@jit
def decode_observations(buf: NDArray[np.uint8], out: NDArray[np.float64]) -> bool:
    """Fill ``out`` (one row per payload, ``messages.OBSERVATION_COLUMNS``) from ``buf``;
    False when a payload holds a latitude or longitude out of range or a non-finite float
    (``_observation_from`` refuses it)."""
    u64 = buf.view(np.uint64)
    i32 = buf.view(np.int32)
    f32 = buf.view(np.float32)
    u16 = buf.view(np.uint16)
    i16 = buf.view(np.int16)
    ok = True
    for r in range(out.shape[0]):
        base = r * RECORD_STRIDE
        w4 = base // 4
        w2 = base // 2
        out[r, 0] = u64[base // 8] / 1e6
        out[r, 1] = i32[w4 + 2] / 1e7
        out[r, 2] = i32[w4 + 3] / 1e7
        out[r, 3] = f32[w4 + 4]
        out[r, 4] = i32[w4 + 5] / 1e7
        out[r, 5] = i32[w4 + 6] / 1e7
        out[r, 6] = f32[w4 + 7]
        out[r, 7] = f32[w4 + 8]
        out[r, 8] = f32[w4 + 9]
        direction = np.int64(u16[w2 + 20])
        out[r, 9] = np.nan if direction > _UNKNOWN_DIRECTION_ABOVE else direction / 100
        speed_h = np.int64(u16[w2 + 21])
        out[r, 10] = np.nan if speed_h == _UNKNOWN_SPEED_H_CMS else speed_h / 100.0
        speed_v = np.int64(i16[w2 + 22])
        out[r, 11] = np.nan if speed_v == _UNKNOWN_SPEED_V_CMS else speed_v / 100.0
        if not (
            abs(out[r, 1]) <= 90.0
            and abs(out[r, 2]) <= 180.0
            and abs(out[r, 4]) <= 90.0
            and abs(out[r, 5]) <= 180.0
            and np.isfinite(out[r, 3])
            and np.isfinite(out[r, 6])
            and np.isfinite(out[r, 7])
            and np.isfinite(out[r, 8])
        ):
            ok = False
    return ok
