"""MAVLink 2 packets framed and checked many at once, compiled. Framing
(``link.frame_rid_reports``): the sim's radio hands each companion the frames it heard, some
4,000 RIDSAFE_RID_FRAME packets a second at 64 aircraft, and every report of one frame differs
from the others only in its first field, the signal strength. Checking
(``MavlinkLink.feed``): a datagram of well-formed packets (most of them: a companion's
second of reports, a tick's heard frames) is cut into its packets and their CRCs checked in one
call, before any of them is decoded.

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
_IFLAG_SIGNED = 0x01
_SIGNATURE_BYTES = 13


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


#: ``scan_packets``'s answer for a datagram it leaves to the byte-by-byte parser.
NOT_PLAIN = -1


@jit
def scan_packets(
    buf: NDArray[np.uint8], crc_extra: NDArray[np.int16], ends: NDArray[np.int64]
) -> int:
    """How many packets ``buf`` holds, each packet k ending at ``ends[k]``, when it is
    nothing but whole MAVLink 2 packets one after another, each with no unknown
    incompatibility flag, a message id whose CRC extra ``crc_extra`` has (-1: unknown) and a
    matching CRC; else ``NOT_PLAIN`` (garbage, a partial packet, an unknown id, a bad CRC:
    the parser then says which). Signatures are not checked here. ``ends`` holds at least
    ``len(buf) // (HEADER_BYTES + CRC_BYTES)`` entries."""
    n = buf.shape[0]
    at = 0
    count = 0
    while at < n:
        if buf[at] != _STX_V2 or n - at < HEADER_BYTES + CRC_BYTES:
            return NOT_PLAIN
        length, incompat = buf[at + 1], buf[at + 2]
        if incompat & ~_IFLAG_SIGNED:
            return NOT_PLAIN
        crc_at = at + HEADER_BYTES + length
        end = crc_at + CRC_BYTES + (_SIGNATURE_BYTES if incompat & _IFLAG_SIGNED else 0)
        msg_id = np.int64(buf[at + 7]) | np.int64(buf[at + 8]) << 8 | np.int64(buf[at + 9]) << 16
        if end > n or msg_id >= crc_extra.shape[0] or crc_extra[msg_id] < 0:
            return NOT_PLAIN
        crc = 0xFFFF
        for j in range(at + 1, crc_at):
            crc = _crc_accumulate(buf[j], crc)
        crc = _crc_accumulate(crc_extra[msg_id], crc)
        if crc != (np.int64(buf[crc_at]) | np.int64(buf[crc_at + 1]) << 8):
            return NOT_PLAIN
        ends[count] = end
        count += 1
        at = end
    return count
