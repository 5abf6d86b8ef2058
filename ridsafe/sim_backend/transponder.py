"""A vehicle's Remote ID transponder: MAVLink component 236 (MAV_COMP_ID_ODID_TXRX_1).

Transmit: an OPEN_DRONE_ID_* message from the companion is encoded to its 25-byte ASTM F3411
form (rejected inputs are logged and counted, never put on the air). LOCATION (and
AUTHENTICATION / MESSAGE_PACK) frames go on the air as they come; the static messages
(BASIC_ID, SYSTEM, OPERATOR_ID, SELF_ID) are kept and re-broadcast on the transponder's own
cadence, every ``STATIC_PERIOD_S`` (ASTM F3411 asks for them at least every 3 s), however
often the companion refreshes them: together in one message pack (``static_as_pack``, as
Bluetooth 5 long range and Wi-Fi broadcasts carry them), or one frame each (Bluetooth 4
legacy advertising).
Receive: a frame from the air is decoded and handed to the companion as the matching
OPEN_DRONE_ID_* message with ``id_or_mac`` set to the sender's radio id (a message pack as
one OPEN_DRONE_ID_MESSAGE_PACK, after checking every message in it decodes), followed by one
RIDSAFE_RID_RSSI with the frame's signal strength, F3411 type and receive time. Quantisation
on the air is therefore real: receivers see exactly what F3411 can carry.

ARM_STATUS follows ArduPilot's expectation: ready (status 0) once the companion has sent
BASIC_ID, SYSTEM and LOCATION within the last 3 s, otherwise status 1 with the reason.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

from ridsafe.common import codec, f3411
from ridsafe.common import messages as m
from ridsafe.common.errors import RidsafeError

logger = logging.getLogger(__name__)

TRANSPONDER_COMPONENT = 236
ARM_STATUS_MAX_AGE_S = 3.0
STATIC_PERIOD_S = 3.0

_BROADCAST_TYPES = (
    m.OdidBasicId,
    m.OdidLocation,
    m.OdidSystem,
    m.OdidOperatorId,
    m.OdidSelfId,
    m.OdidRaw,
)
STATIC_TYPES = (m.OdidBasicId, m.OdidSystem, m.OdidOperatorId, m.OdidSelfId)
_REQUIRED_FOR_ARMING = {"OPEN_DRONE_ID_BASIC_ID", "OPEN_DRONE_ID_SYSTEM", "OPEN_DRONE_ID_LOCATION"}


@dataclass
class TransponderCounters:
    sent: int = 0
    encode_rejected: int = 0
    received: int = 0
    decode_failed: int = 0


class Transponder:
    """Sans-I/O RID transponder of vehicle ``sysid`` whose radio id is ``radio_id``."""

    def __init__(
        self,
        sysid: int,
        radio_id: bytes,
        static_phase_s: float = 0.0,
        static_as_pack: bool = True,
    ) -> None:
        self.sysid = sysid
        self.static_as_pack = static_as_pack
        self.radio_id = radio_id
        self.counters = TransponderCounters()
        self._last_from_companion_s: dict[str, float] = {}
        self._system: m.OdidSystem | None = None
        self._static_frames: dict[str, bytes] = {}
        self._next_static_s = static_phase_s

    def heartbeat(self) -> m.Heartbeat:
        return m.Heartbeat(m.MavType.ODID, m.MavAutopilot.INVALID, 0, 0, int(m.MavState.ACTIVE))

    def on_message(self, now_s: float, message: m.Message) -> bytes | None:
        """An ODID message from the companion; returns the F3411 frame to put on the air now
        (None for a static message, which waits for ``due_static``, or a rejected one)."""
        if isinstance(message, m.OdidSystemUpdate):
            updated = self._apply_system_update(message)
            if updated is None:
                return None
            message = updated
        if not isinstance(message, _BROADCAST_TYPES):
            return None
        try:
            name, fields = codec.odid_fields(message)
            frame = f3411.encode(name, fields)
        except (RidsafeError, ValueError) as exc:  # UnicodeError is a ValueError
            self.counters.encode_rejected += 1
            logger.warning(
                "transponder %d: not broadcasting %s: %s", self.sysid, type(message).__name__, exc
            )
            return None
        self._last_from_companion_s[name] = now_s
        if isinstance(message, m.OdidSystem):
            self._system = message
        if isinstance(message, STATIC_TYPES):
            self._static_frames[name] = frame
            return None
        self.counters.sent += 1
        return frame

    @property
    def static_frames(self) -> dict[str, bytes]:
        """The static frames (by MAVLink message name) the next static slot will send."""
        return dict(self._static_frames)

    def due_static(self, now_s: float) -> list[bytes]:
        """The static frames to re-broadcast now (every ``STATIC_PERIOD_S``): one message
        pack of them all with ``static_as_pack`` (a lone message goes alone)."""
        if now_s < self._next_static_s - 1e-9:
            return []
        missed = math.floor((now_s - self._next_static_s) / STATIC_PERIOD_S + 1e-9)
        self._next_static_s += (max(missed, 0) + 1) * STATIC_PERIOD_S
        frames = list(self._static_frames.values())
        if self.static_as_pack and len(frames) > 1:
            frames = [f3411.pack(frames)]
        self.counters.sent += len(frames)
        return frames

    def _apply_system_update(self, update: m.OdidSystemUpdate) -> m.OdidSystem | None:
        """SYSTEM_UPDATE refreshes the operator location of the last full SYSTEM message."""
        if self._system is None:
            logger.info("transponder %d: SYSTEM_UPDATE before any SYSTEM, ignored", self.sysid)
            return None
        s = self._system
        return m.OdidSystem(
            s.id_or_mac,
            s.operator_location_type,
            s.classification_type,
            update.operator_lat_deg,
            update.operator_lon_deg,
            s.area_count,
            s.area_radius_m,
            s.area_ceiling_m,
            s.area_floor_m,
            s.category_eu,
            s.class_eu,
            update.operator_alt_geo_m,
            update.timestamp_s,
        )

    def receive(
        self, now_s: float, frame: bytes, sender_id: bytes, rssi_dbm: float
    ) -> list[m.Message]:
        """A frame heard on the air -> OPEN_DRONE_ID_* (+ RIDSAFE_RID_RSSI) for the companion."""
        return self.hand_over(now_s, decode_frame(frame, sender_id), sender_id, rssi_dbm)

    def hand_over(
        self, now_s: float, decoded: DecodedFrame, sender_id: bytes, rssi_dbm: float
    ) -> list[m.Message]:
        """What this transponder gives its companion for a frame ``decode_frame`` decoded
        (decoding once serves every receiver of a transmission): the message, then the
        frame's RSSI."""
        self.counters.decode_failed += decoded.failures
        if decoded.message is None:
            return []
        self.counters.received += 1
        return [decoded.message, m.RidRssi(now_s, rssi_dbm, sender_id, decoded.msg_type)]

    def arm_status(self, now_s: float) -> m.OdidArmStatus:
        missing = sorted(
            name.removeprefix("OPEN_DRONE_ID_")
            for name in _REQUIRED_FOR_ARMING
            if now_s - self._last_from_companion_s.get(name, -1e9) > ARM_STATUS_MAX_AGE_S
        )
        if missing:
            return m.OdidArmStatus(1, f"missing {','.join(missing)}"[:50])
        return m.OdidArmStatus(0, "")

    def ready_error(self, now_s: float) -> str | None:
        status = self.arm_status(now_s)
        return status.error if status.status else None


@dataclass(frozen=True)
class DecodedFrame:
    """A frame from the air as the OPEN_DRONE_ID_* message for the companion (``id_or_mac`` =
    the sender; None when it cannot be handed over) and its F3411 type; ``failures`` counts
    parts that could not be decoded."""

    message: m.Message | None
    msg_type: int
    failures: int = 0


def decode_frame(frame: bytes, sender_id: bytes) -> DecodedFrame:
    """Decode a frame from the air (a single message, or a message pack whose messages must
    all decode: a receiver hands on no pack it could not read)."""
    id_or_mac = list(sender_id.ljust(20, b"\x00"))
    try:
        msg_type = int(f3411.message_type(frame))
        decoded = f3411.decode(frame)
        if msg_type == f3411.MessageType.MESSAGE_PACK:
            f3411.decode_pack(frame)
    except RidsafeError as exc:
        logger.warning("undecodable frame from %r: %s", sender_id, exc)
        return DecodedFrame(None, -1, 1)
    name, fields = decoded
    try:
        message = codec.message_from_fields(name, dict(fields, id_or_mac=id_or_mac))
    except (RidsafeError, ValueError, TypeError) as exc:
        logger.warning("cannot hand over %s from %r: %s", name, sender_id, exc)
        return DecodedFrame(None, msg_type, 1)
    return DecodedFrame(message, msg_type)
