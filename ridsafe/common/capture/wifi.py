"""Remote ID in 802.11 management frames: the beacon vendor element and NAN service discovery.

The layouts (ASTM F3411-22a Wi-Fi transports, as opendroneid-core-c builds them):

- Management header, 24 bytes: frame control u16 LE (type 0; subtype 8 beacon, 13 action,
  14 action no-ack), duration, addr1 (destination), addr2 (source: the sender's MAC), addr3,
  sequence control; 4 more bytes of HT control when the frame control's +HTC/order bit is set.
- **Beacon**: timestamp u64, beacon interval u16, capability u16, then information elements
  (id u8, length u8, body). Remote ID is a vendor-specific element (id 221) whose body is
  OUI ``FA-0B-BC`` (ASD-STAN), OUI type ``0x0D``, a message counter u8 and one F3411 message
  pack.
- **NAN service discovery frame** (Wi-Fi Aware): a public action frame, category 4, action 9
  (vendor specific), OUI ``50-6F-9A`` (Wi-Fi Alliance), OUI type ``0x13`` (NAN), then NAN
  attributes (id u8, length u16 LE, body). Remote ID is a Service Descriptor attribute (id 3)
  whose service id is the first 6 bytes of SHA-256("org.opendroneid.remoteid"): service id
  [6], instance id, requestor instance id, service control; then, as the control's bits say,
  binding bitmap u16 (bit 6), matching filter (bit 2: length u8 + bytes), service response
  filter (bit 3: length u8 + bytes) and service info (bit 4: length u8 + bytes). The service
  info is a message counter u8 and one F3411 message pack.

A frame with none of these is not Remote ID (``[]``); one that claims to be and is cut short
raises :class:`WifiFrameError`.
"""

from __future__ import annotations

import hashlib
import struct
from dataclasses import dataclass

from ridsafe.common import messages as m

__all__ = [
    "ASD_STAN_OUI",
    "NAN_REMOTE_ID_SERVICE_ID",
    "RidPayload",
    "WifiFrameError",
    "format_mac",
    "remote_id_payloads",
]


class WifiFrameError(ValueError):
    """An 802.11 frame that announces Remote ID but cannot be read."""


@dataclass(frozen=True, slots=True)
class RidPayload:
    """F3411 bytes found in one frame: how they travelled, from whom, the sender's message
    counter (None where the transport has none) and the frame (one message or a pack)."""

    transport: m.RidTransport
    sender_mac: str
    counter: int | None
    frame: bytes


ASD_STAN_OUI = bytes.fromhex("fa0bbc")
ODID_OUI_TYPE = 0x0D
WFA_OUI = bytes.fromhex("506f9a")
NAN_OUI_TYPE = 0x13
NAN_REMOTE_ID_SERVICE_ID = hashlib.sha256(b"org.opendroneid.remoteid").digest()[:6]
ELEMENT_VENDOR = 221
ATTRIBUTE_SERVICE_DESCRIPTOR = 0x03
SUBTYPE_BEACON, SUBTYPE_ACTION, SUBTYPE_ACTION_NO_ACK = 8, 13, 14
PUBLIC_ACTION, VENDOR_SPECIFIC_ACTION = 4, 9
MGMT_HEADER_LEN, HT_CONTROL_LEN, BEACON_FIXED_LEN = 24, 4, 12
FC_ORDER = 0x8000
SC_BINDING_BITMAP, SC_MATCHING_FILTER, SC_RESPONSE_FILTER, SC_SERVICE_INFO = 0x40, 4, 8, 0x10


def format_mac(raw: bytes) -> str:
    """``aa:bb:cc:dd:ee:ff`` (transmission order)."""
    return ":".join(f"{b:02x}" for b in raw)


def remote_id_payloads(frame: bytes) -> list[RidPayload]:
    """The Remote ID carried by one 802.11 frame (no FCS), in frame order."""
    if len(frame) < MGMT_HEADER_LEN:
        return []
    control = struct.unpack_from("<H", frame)[0]
    kind, subtype = (control >> 2) & 0x3, (control >> 4) & 0xF
    if kind != 0:
        return []
    body_at = MGMT_HEADER_LEN + (HT_CONTROL_LEN if control & FC_ORDER else 0)
    sender = format_mac(frame[10:16])
    body = frame[body_at:]
    if subtype == SUBTYPE_BEACON:
        return _beacon(body, sender)
    if subtype in (SUBTYPE_ACTION, SUBTYPE_ACTION_NO_ACK):
        return _nan(body, sender)
    return []


def _with_counter(transport: m.RidTransport, sender: str, info: bytes, where: str) -> RidPayload:
    if len(info) < 2:
        raise WifiFrameError(f"{where}: {len(info)} bytes, no message counter and pack")
    return RidPayload(transport, sender, info[0], bytes(info[1:]))


def _beacon(body: bytes, sender: str) -> list[RidPayload]:
    found: list[RidPayload] = []
    position = BEACON_FIXED_LEN
    while position + 2 <= len(body):
        element, length = body[position], body[position + 1]
        value = body[position + 2 : position + 2 + length]
        if len(value) < length:
            if found or _is_odid_vendor(value):
                raise WifiFrameError(f"element {element} at body byte {position} cut short")
            return found
        if element == ELEMENT_VENDOR and _is_odid_vendor(value):
            info = value[4:]
            found.append(_with_counter(m.RidTransport.WIFI_BEACON, sender, info, "beacon element"))
        position += 2 + length
    return found


def _is_odid_vendor(value: bytes) -> bool:
    return value[:3] == ASD_STAN_OUI and len(value) >= 4 and value[3] == ODID_OUI_TYPE


def _nan(body: bytes, sender: str) -> list[RidPayload]:
    if len(body) < 6 or body[0] != PUBLIC_ACTION or body[1] != VENDOR_SPECIFIC_ACTION:
        return []
    if body[2:5] != WFA_OUI or body[5] != NAN_OUI_TYPE:
        return []
    found: list[RidPayload] = []
    position = 6
    while position + 3 <= len(body):
        attribute, length = body[position], struct.unpack_from("<H", body, position + 1)[0]
        value = body[position + 3 : position + 3 + length]
        if len(value) < length:
            raise WifiFrameError(f"NAN attribute {attribute} at body byte {position} cut short")
        if attribute == ATTRIBUTE_SERVICE_DESCRIPTOR and value[:6] == NAN_REMOTE_ID_SERVICE_ID:
            info = _service_info(value)
            found.append(_with_counter(m.RidTransport.WIFI_NAN, sender, info, "NAN service info"))
        position += 3 + length
    return found


def _service_info(value: bytes) -> bytes:
    """The service info of a Service Descriptor attribute (after id, instances, control)."""
    if len(value) < 9:
        raise WifiFrameError(f"service descriptor of {len(value)} bytes, needs 9")
    control, position = value[8], 9
    if control & SC_BINDING_BITMAP:
        position += 2
    for bit in (SC_MATCHING_FILTER, SC_RESPONSE_FILTER):
        if control & bit:
            if position >= len(value):
                raise WifiFrameError("service descriptor filter length missing")
            position += 1 + value[position]
    if not control & SC_SERVICE_INFO:
        raise WifiFrameError(f"Remote ID service descriptor without service info ({control:#x})")
    if position >= len(value):
        raise WifiFrameError("service info length missing")
    length = value[position]
    info = value[position + 1 : position + 1 + length]
    if len(info) < length:
        raise WifiFrameError(f"service info of {length} bytes, {len(info)} present")
    return info
