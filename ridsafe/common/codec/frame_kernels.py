"""Many MAVLink 2 packets of one kind framed at once, compiled (``link.
frame_rid_reports``): the sim's radio hands each companion the frames it heard, some 4,000
RIDSAFE_RID_FRAME packets a second at 64 aircraft, and every report of one frame differs from
the others only in its first field, the signal strength.

The packet is the one ``MavlinkLink.frame`` makes: the header (start marker, payload length,
incompatibility flags, compatibility flags 0, sequence number, system, component, message id),
the payload with its trailing zeros trimmed (at least one byte kept), and the X.25 CRC of
everything after the start marker and then the message's CRC extra, little-endian.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.jit import jit, jit_inline

#: Header and CRC bytes around a payload.
HEADER_BYTES = 10
CRC_BYTES = 2
#: The varying head of each payload: a float32.
HEAD_BYTES = 4
_STX_V2 = 0xFD


@jit_inline
def _crc_accumulate(byte: int, crc: int) -> int:
    """MAVLink's ``crc_accumulate`` (CRC-16/MCRF4XX, one byte)."""
    tmp = (byte ^ (crc & 0xFF)) & 0xFF
    tmp = (tmp ^ (tmp << 4)) & 0xFF
    return ((crc >> 8) ^ (tmp << 8) ^ (tmp << 3) ^ (tmp >> 4)) & 0xFFFF


@jit
def frame_headed(
    heads: NDArray[np.float32],
    tails: NDArray[np.uint8],
    tail_start: NDArray[np.int64],
    tail_length: NDArray[np.int64],
    tail_of: NDArray[np.int64],
    seq_system_component: NDArray[np.int64],
    header: NDArray[np.int64],
    out: NDArray[np.uint8],
    ends: NDArray[np.int64],
) -> None:
    """Packet i (payload: ``heads[i]`` as a little-endian float32, then tail ``tail_of[i]``,
    trailing zeros trimmed; sequence number, system and component
    ``seq_system_component[i]``) into ``out`` after packet i - 1, ending at ``ends[i]``.
    ``header``: incompatibility flags, message id, CRC extra. ``out`` holds at least every
    untrimmed packet."""
    incompat, msg_id, crc_extra = header[0], header[1], header[2]
    head_bytes = heads.view(np.uint8)
    at = 0
    for i in range(heads.shape[0]):
        payload = at + HEADER_BYTES
        for b in range(HEAD_BYTES):
            out[payload + b] = head_bytes[HEAD_BYTES * i + b]
        t0, n_tail = tail_start[tail_of[i]], tail_length[tail_of[i]]
        out[payload + HEAD_BYTES : payload + HEAD_BYTES + n_tail] = tails[t0 : t0 + n_tail]
        length = HEAD_BYTES + n_tail
        while length > 1 and out[payload + length - 1] == 0:
            length -= 1
        seq, system, component = seq_system_component[i]
        out[at], out[at + 1], out[at + 2], out[at + 3] = _STX_V2, length, incompat, 0
        out[at + 4], out[at + 5], out[at + 6] = seq & 0xFF, system, component
        out[at + 7], out[at + 8], out[at + 9] = msg_id & 0xFF, (msg_id >> 8) & 0xFF, msg_id >> 16
        crc = 0xFFFF
        for j in range(at + 1, payload + length):
            crc = _crc_accumulate(out[j], crc)
        crc = _crc_accumulate(crc_extra, crc)
        out[payload + length], out[payload + length + 1] = crc & 0xFF, crc >> 8
        at = payload + length + CRC_BYTES
        ends[i] = at
