"""A vehicle's Remote ID transponder: MAVLink component 236 (MAV_COMP_ID_ODID_TXRX_1).

Transmit: an OPEN_DRONE_ID_* message from the companion is encoded to its 25-byte ASTM F3411
form (rejected inputs are logged and counted, never put on the air). LOCATION (and
AUTHENTICATION / MESSAGE_PACK) frames go on the air as they come; the static messages
(BASIC_ID, SYSTEM, OPERATOR_ID, SELF_ID) are kept and re-broadcast on the transponder's own
cadence, every ``STATIC_PERIOD_S`` (ASTM F3411 asks for them at least every 3 s), however
often the companion refreshes them: together in one message pack (``static_as_pack``, as
Bluetooth 5 long range and Wi-Fi broadcasts carry them), or one frame each (Bluetooth 4
legacy advertising).
Receive: a frame from the air goes to the companion whole, as one RIDSAFE_RID_FRAME: the
F3411 bytes with their signal strength and the sender's radio id (``report``); the
companion decodes the messages inside (``common.heard``). Quantisation on the air is
therefore real: receivers see exactly what F3411 can carry.

ARM_STATUS follows ArduPilot's expectation: ready (status 0) once the companion has sent
BASIC_ID, SYSTEM and LOCATION within the last 3 s, otherwise status 1 with the reason.
"""

from __future__ import annotations

import itertools
import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ridsafe.common import codec, f3411
from ridsafe.common import messages as m
from ridsafe.common.errors import RidsafeError, WireError
from ridsafe.sim_backend.radio import Receptions, Transmission

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
        # per static message type: the last message encoded, its name and frame
        self._last_static: dict[type, tuple[m.Message, str, bytes]] = {}
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
        encoded = self._encoded(message)
        if encoded is None:
            return None
        name, frame = encoded
        self._last_from_companion_s[name] = now_s
        if isinstance(message, m.OdidSystem):
            self._system = message
        if isinstance(message, STATIC_TYPES):
            self._static_frames[name] = frame
            return None
        self.counters.sent += 1
        return frame

    def _encoded(self, message: m.Message) -> tuple[str, bytes] | None:
        """(MAVLink message name, F3411 frame) of ``message``, or None if it cannot go on
        the air (logged and counted). A static message the companion repeats unchanged
        (BASIC_ID, OPERATOR_ID: the same every few seconds) is not encoded again."""
        last = self._last_static.get(type(message))
        if last is not None and last[0] == message:
            return last[1], last[2]
        try:
            name, fields = codec.odid_fields(message)
            frame = f3411.encode(name, fields)
        except (RidsafeError, ValueError) as exc:  # UnicodeError is a ValueError
            self.counters.encode_rejected += 1
            logger.warning(
                "transponder %d: not broadcasting %s: %s", self.sysid, type(message).__name__, exc
            )
            return None
        if isinstance(message, STATIC_TYPES):
            self._last_static[type(message)] = (message, name, frame)
        return name, frame

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

    def report(self, frame: bytes, sender_id: bytes, rssi_dbm: float) -> m.RidFrameReport:
        """What this transponder tells its companion about a frame it heard: the frame as it
        came off the air, whole, with its signal strength and the sender's radio id (one
        RIDSAFE_RID_FRAME; the companion reads the messages inside)."""
        self.counters.received += 1
        return heard_report(frame, sender_id, rssi_dbm)

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


def heard_report(frame: bytes, sender_id: bytes, rssi_dbm: float) -> m.RidFrameReport:
    """The report of a frame a simulated transponder heard (``Transponder.report``)."""
    return m.RidFrameReport(frame, rssi_dbm, sender_id, int(m.RidTransport.SIMULATED))


def frame_heard_together(
    transponders: Sequence[Transponder],
    links: Sequence[codec.MavlinkLink | None],
    transmissions: Sequence[Transmission],
    heard: Receptions,
) -> list[tuple[int, list[bytes]]] | None:
    """(receiver, its packets) of every receiver with a link to its companion (``links``, by
    vehicle index; None: none): the RIDSAFE_RID_FRAME packets ``Transponder.report`` of each
    reception, in the order heard, would make, framed in one compiled pass
    (``codec.frame_rid_reports``); every transponder's receptions counted. None, having
    framed and counted nothing, where they cannot be (a frame that cannot be sent, a signed
    link)."""
    order = np.argsort(heard.receiver, kind="stable")  # by receiver, each in the order heard
    receivers = heard.receiver[order]
    cuts = [0, *(np.flatnonzero(np.diff(receivers)) + 1).tolist(), len(order)]
    groups = [(int(receivers[a]), a, b) for a, b in itertools.pairwise(cuts)]
    to = [
        (receiver, link, a, b) for receiver, a, b in groups if (link := links[receiver]) is not None
    ]
    try:
        tails = codec.RidFrameTails.of(
            [heard_report(tx.payload, transponders[tx.sender].radio_id, 0.0)
             for tx in transmissions]
        )  # fmt: skip
    except WireError:  # each report then says so on its own
        return None
    chosen = np.concatenate([np.zeros(0, np.int64), *(np.arange(a, b) for *_, a, b in to)])
    packets = codec.frame_rid_reports(
        [link for _, link, _, _ in to],
        [b - a for *_, a, b in to],
        tails,
        heard.transmission[order][chosen],
        heard.rssi_dbm[order][chosen],
    )
    if packets is None:
        return None
    for receiver, a, b in groups:
        transponders[receiver].counters.received += b - a
    return [(receiver, framed) for (receiver, *_), framed in zip(to, packets, strict=True)]
