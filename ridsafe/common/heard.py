"""A Remote ID frame as a receiver heard it, and what is inside it.

``HeardRidFrame`` is one reception, whole: when it was heard (on the clock of the app that
holds it) and the receiver's report of it (``messages.RidFrameReport``: the ASTM F3411 bytes,
their RSSI, the sender as the radio layer knows it, the transport). Frame and RSSI never
travel apart: the sim radio makes one report per reception, the transponder link carries it
as one RIDSAFE_RID_FRAME, a capture of a real receiver (Wi-Fi beacon / NAN, Bluetooth
advertising) makes the same report from each packet it captured.

``RidFrameDecoder`` reads the messages inside a frame: one OPEN_DRONE_ID_* domain message, or
every message of a message pack, each with ``id_or_mac`` set to the sender id (as a real
transponder hands them over), and what each LOCATION among them claims (``LocationClaim``:
the claimed id as text, position and velocity). Decoding is a pure function of (frame,
sender id); the decoder remembers its last results so that receivers that share one decoder
(explicitly: several companions in one process are given the same one) decode a broadcast,
and read its claims, once.

A claim's velocity from the RID fields::

    v_n = s_h cos(course),   v_e = s_h sin(course),   v_d = -s_v

with unknown speeds taken as 0 (and an unknown course with them: RID reports none below
walking pace).
"""

from __future__ import annotations

import functools
import logging
import math
from dataclasses import dataclass, field

from ridsafe.common import codec, f3411
from ridsafe.common import messages as m
from ridsafe.common.errors import RidsafeError
from ridsafe.common.frozen import quick_init

logger = logging.getLogger(__name__)

__all__ = [
    "DecodedRidFrame",
    "HeardRidFrame",
    "LocationClaim",
    "RidFrameDecoder",
    "claim_of",
    "claimed_id",
    "velocity_ned",
]


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


@functools.lru_cache(maxsize=1024)
def claimed_id(id_or_mac: bytes) -> str:
    """The claimed UAS id as text: printable ASCII kept, anything else as '?'."""
    return "".join(chr(b) if 32 <= b < 127 else "?" for b in id_or_mac[: codec.ODID_ID_LEN])


def velocity_ned(location: m.OdidLocation) -> m.Vec3:
    """NED velocity (m/s) a RID LOCATION claims; unknown parts are 0."""
    speed_h = location.speed_horizontal_m_s or 0.0
    course = location.course_deg
    vn = ve = 0.0
    if course is not None:
        vn = speed_h * math.cos(math.radians(course))
        ve = speed_h * math.sin(math.radians(course))
    speed_v = location.speed_vertical_m_s or 0.0
    return (vn, ve, -speed_v)


@quick_init
@dataclass(frozen=True, slots=True)
class LocationClaim:
    """What one LOCATION claims, read once per decoded frame: the claimed id as text
    (``claimed_id``), the position (lat_deg, lon_deg, alt_m: the geodetic altitude, else the
    barometric one; None when any is unknown) and the NED velocity (``velocity_ned``)."""

    location: m.OdidLocation
    uas_id: str
    position: m.Vec3 | None
    v_ned_m_s: m.Vec3


def claim_of(location: m.OdidLocation) -> LocationClaim:
    alt = location.alt_geodetic_m if location.alt_geodetic_m is not None else location.alt_baro_m
    lat, lon = location.lat_deg, location.lon_deg
    position = None if lat is None or lon is None or alt is None else (lat, lon, alt)
    return LocationClaim(location, claimed_id(location.id_or_mac), position, velocity_ned(location))


@dataclass(frozen=True, slots=True)
class DecodedRidFrame:
    """The messages read from one frame (in frame order) and why the others could not be
    read; ``msg_type`` is the frame's F3411 type (a pack's is MESSAGE_PACK; -1: unreadable).
    ``claims``: what each LOCATION among the messages claims, in order."""

    messages: tuple[m.Message, ...]
    errors: tuple[str, ...] = ()
    msg_type: int = -1
    claims: tuple[LocationClaim, ...] = field(init=False)

    def __post_init__(self) -> None:
        claims = tuple(
            claim_of(message) for message in self.messages if isinstance(message, m.OdidLocation)
        )
        object.__setattr__(self, "claims", claims)

    def locations(self) -> list[m.OdidLocation]:
        return [claim.location for claim in self.claims]


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
