"""A Remote ID frame as a receiver heard it, and what is inside it.

``HeardRidFrame`` is one reception, whole: when it was heard (on the clock of the app that
holds it) and the receiver's report of it (``messages.RidFrameReport``: the ASTM F3411 bytes,
their RSSI, the sender as the radio layer knows it, the transport). Frame and RSSI never
travel apart: the sim radio makes one report per reception, the transponder link carries it
as one RIDSAFE_RID_FRAME, a capture of a real receiver (Wi-Fi beacon / NAN, Bluetooth
advertising) makes the same report from each packet it captured.

``RidFrameDecoder`` reads the messages inside a frame: one OPEN_DRONE_ID_* domain message, or
every message of a message pack, each with ``id_or_mac`` set to the sender id (as a real
transponder hands them over). Decoding is a pure function of (frame, sender id); the decoder
remembers its last results so that receivers that share one decoder (explicitly: several
companions in one process are given the same one) decode a broadcast once.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

from ridsafe.common import codec, f3411
from ridsafe.common import messages as m
from ridsafe.common.errors import RidsafeError
from ridsafe.common.frozen import quick_init

logger = logging.getLogger(__name__)

__all__ = ["DecodedRidFrame", "HeardRidFrame", "RidFrameDecoder"]


@quick_init
@dataclass(frozen=True, slots=True)
class HeardRidFrame:
    """One received Remote ID frame: receive time (s, the holder's clock) and the report."""

    rx_t_s: float
    report: m.RidFrameReport

    @property
    def rssi_dbm(self) -> float:
        return self.report.rssi_dbm

    @property
    def frame(self) -> bytes:
        return self.report.frame

    @property
    def sender_id(self) -> bytes:
        return self.report.sender_id


@dataclass(frozen=True, slots=True)
class DecodedRidFrame:
    """The messages read from one frame (in frame order) and why the others could not be
    read; ``msg_type`` is the frame's F3411 type (a pack's is MESSAGE_PACK; -1: unreadable)."""

    messages: tuple[m.Message, ...]
    errors: tuple[str, ...] = ()
    msg_type: int = -1

    def locations(self) -> list[m.OdidLocation]:
        return [message for message in self.messages if isinstance(message, m.OdidLocation)]


class RidFrameDecoder:
    """ASTM F3411 frames -> domain messages, remembering the last ``max_entries`` results."""

    def __init__(self, max_entries: int = 1024) -> None:
        if max_entries < 1:
            raise ValueError(f"max_entries must be >= 1, got {max_entries}")
        self.max_entries = max_entries
        self._done: dict[tuple[bytes, bytes], DecodedRidFrame] = {}

    def decode(self, frame: bytes, sender_id: bytes) -> DecodedRidFrame:
        key = (frame, sender_id)
        decoded = self._done.get(key)
        if decoded is None:
            decoded = decode_rid_frame(frame, sender_id)
            if len(self._done) >= self.max_entries:
                self._done.clear()
            self._done[key] = decoded
        return decoded


def decode_rid_frame(frame: bytes, sender_id: bytes) -> DecodedRidFrame:
    """Read one frame: a single message, or each message of a pack (one that does not
    decode is named in ``errors``; the others still count). Never raises."""
    id_or_mac = list(sender_id[: codec.ODID_ID_LEN].ljust(codec.ODID_ID_LEN, b"\x00"))
    try:
        msg_type = int(f3411.message_type(frame))
        parts = f3411.split_pack(frame) if msg_type == f3411.MessageType.MESSAGE_PACK else [frame]
    except RidsafeError as exc:
        return DecodedRidFrame((), (f"frame: {exc}",))
    messages: list[m.Message] = []
    errors: list[str] = []
    for index, part in enumerate(parts):
        try:
            name, fields = f3411.decode(part)
            messages.append(codec.message_from_fields(name, dict(fields, id_or_mac=id_or_mac)))
        except (RidsafeError, ValueError, TypeError) as exc:
            errors.append(f"message {index}: {exc}")
    return DecodedRidFrame(tuple(messages), tuple(errors), msg_type)
