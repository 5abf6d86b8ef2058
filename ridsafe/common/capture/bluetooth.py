"""Remote ID in Bluetooth LE advertising, as an HCI controller reports it (with RSSI).

HCI packets (Bluetooth Core 5.x, vol 4 part E):

- Event packet: event code u8, parameter length u8, parameters. LE Meta event (0x3E): the
  first parameter is the sub-event code.
- LE Advertising Report (sub-event 0x02, legacy advertising): Num_Reports u8, then per report
  event type u8, address type u8, address [6] (least significant byte first), data length
  u8, data, RSSI int8 (127: not available). Reports are read one after the other, as BlueZ
  and Wireshark read them.
- LE Extended Advertising Report (sub-event 0x0D): Num_Reports u8, then per report event type
  u16 LE (bit 4: a legacy PDU; bits 5-6 data status: 0 complete, 1 more to come, 2
  truncated), address type, address [6], primary PHY, secondary PHY, advertising SID,
  TX power int8, RSSI int8 (127: not available), periodic interval u16, direct address type,
  direct address [6], data length u8, data. Data marked "more to come" is joined with the
  next report from the same address and SID.

The advertising data is a list of AD structures (length u8 counting the type, type u8,
value). Remote ID (ASTM F3411-22a Bluetooth transport) is Service Data - 16-bit UUID (type
0x16) with UUID 0xFFFA (little-endian ``FA FF``), application code 0x0D, a message counter u8,
then one 25-byte F3411 message (legacy advertising, Bluetooth 4) or a message or message pack
(extended advertising, Bluetooth 5; reported as BLUETOOTH_LONG_RANGE whatever the PHY).

How the HCI packet is framed depends on the capture's link type (``hci_event``).
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass, field

from ridsafe.common import messages as m
from ridsafe.common.capture.containers import LinkType
from ridsafe.common.capture.wifi import format_mac

__all__ = [
    "HCI_LINK_TYPES",
    "AdvertisingReport",
    "BluetoothError",
    "ExtendedJoiner",
    "hci_event",
    "le_reports",
]


class BluetoothError(ValueError):
    """An HCI event that announces advertising reports but cannot be read."""


@dataclass(frozen=True, slots=True)
class AdvertisingReport:
    """One advertisement as the controller reported it (``rssi_dbm`` None: not available)."""

    transport: m.RidTransport
    address: str
    rssi_dbm: int | None
    data: bytes
    sid: int = 0
    status: int = 0  # extended reports' data status


H4_EVENT = 0x04
MONITOR_EVENT = 0x03
UNENCAPSULATED_EVENT_RECEIVED = 0x03  # btsnoop 1001 flags: bit 1 command/event, bit 0 received
LE_META_EVENT = 0x3E
LE_ADVERTISING_REPORT, LE_EXTENDED_ADVERTISING_REPORT = 0x02, 0x0D
RSSI_NOT_AVAILABLE = 127
EXT_LEGACY_PDU = 0x10
STATUS_COMPLETE, STATUS_MORE, STATUS_TRUNCATED = 0, 1, 2
AD_SERVICE_DATA_16 = 0x16
ODID_UUID = 0xFFFA
ODID_APP_CODE = 0x0D
_EXT_FIXED = struct.Struct("<HB6sBBBbbHB6sB")


def _h4(data: bytes, flags: int) -> bytes | None:
    return data[1:] if data[:1] == bytes([H4_EVENT]) else None


def _h4_with_phdr(data: bytes, flags: int) -> bytes | None:
    return _h4(data[4:], flags)  # direction u32 in front


def _monitor(data: bytes, flags: int) -> bytes | None:
    """pcap 254: adapter u16, opcode u16 (big-endian) in front of the packet."""
    if len(data) >= 4 and struct.unpack_from(">H", data, 2)[0] == MONITOR_EVENT:
        return data[4:]
    return None


def _btsnoop_monitor(data: bytes, flags: int) -> bytes | None:
    """btsnoop 2001: (adapter << 16) | opcode in the record's flags, the packet as is."""
    return data if flags & 0xFFFF == MONITOR_EVENT else None


def _unencapsulated(data: bytes, flags: int) -> bytes | None:
    return data if flags & 0x3 == UNENCAPSULATED_EVENT_RECEIVED else None


_EVENT_FRAMING: dict[int, Callable[[bytes, int], bytes | None]] = {
    LinkType.BLUETOOTH_HCI_H4: _h4,
    LinkType.BLUETOOTH_HCI_H4_WITH_PHDR: _h4_with_phdr,
    LinkType.BLUETOOTH_LINUX_MONITOR: _monitor,
    LinkType.BTSNOOP_HCI_UNENCAPSULATED: _unencapsulated,
    LinkType.BTSNOOP_LINUX_MONITOR: _btsnoop_monitor,
}
HCI_LINK_TYPES = frozenset(_EVENT_FRAMING)


def hci_event(link_type: int, data: bytes, flags: int) -> bytes | None:
    """The HCI event packet inside one record (None: the record is no event)."""
    framing = _EVENT_FRAMING.get(link_type)
    return None if framing is None else framing(data, flags)


def le_reports(event: bytes) -> list[AdvertisingReport]:
    """The advertising reports of one HCI event (``[]`` for any other event)."""
    if len(event) < 3 or event[0] != LE_META_EVENT:
        return []
    params = event[2 : 2 + event[1]]
    if len(params) < event[1]:
        raise BluetoothError(f"LE meta event claims {event[1]} bytes, has {len(params)}")
    if not params:
        raise BluetoothError("LE meta event without a subevent code (length 0)")
    if params[0] == LE_ADVERTISING_REPORT:
        return _legacy(params[1:])
    if params[0] == LE_EXTENDED_ADVERTISING_REPORT:
        return _extended(params[1:])
    return []


def _rssi(value: int) -> int | None:
    return None if value == RSSI_NOT_AVAILABLE else value


def _legacy(params: bytes) -> list[AdvertisingReport]:
    if not params:
        raise BluetoothError("advertising report without Num_Reports")
    reports, position = [], 1
    for index in range(params[0]):
        if position + 9 > len(params):
            raise BluetoothError(f"advertising report {index} cut short at byte {position}")
        address = format_mac(params[position + 2 : position + 8][::-1])
        length = params[position + 8]
        data = params[position + 9 : position + 9 + length]
        end = position + 9 + length
        if end >= len(params):
            raise BluetoothError(f"advertising report {index}: {length} data bytes + RSSI missing")
        rssi = struct.unpack_from("<b", params, end)[0]
        reports.append(
            AdvertisingReport(m.RidTransport.BLUETOOTH_LEGACY, address, _rssi(rssi), data)
        )
        position = end + 1
    return reports


def _extended(params: bytes) -> list[AdvertisingReport]:
    if not params:
        raise BluetoothError("extended advertising report without Num_Reports")
    reports, position = [], 1
    for index in range(params[0]):
        if position + _EXT_FIXED.size > len(params):
            raise BluetoothError(f"extended report {index} cut short at byte {position}")
        kind, _atype, raw, _p1, _p2, sid, _tx, rssi, _iv, _dtype, _daddr, length = (
            _EXT_FIXED.unpack_from(params, position)
        )
        start = position + _EXT_FIXED.size
        data = params[start : start + length]
        if len(data) < length:
            raise BluetoothError(f"extended report {index}: {length} data bytes, {len(data)} here")
        transport = (
            m.RidTransport.BLUETOOTH_LEGACY
            if kind & EXT_LEGACY_PDU
            else m.RidTransport.BLUETOOTH_LONG_RANGE
        )
        status = (kind >> 5) & 0x3
        reports.append(
            AdvertisingReport(transport, format_mac(raw[::-1]), _rssi(rssi), data, sid, status)
        )
        position = start + length
    return reports


@dataclass
class ExtendedJoiner:
    """Joins extended reports marked "more to come" with the rest from the same sender."""

    _partial: dict[tuple[str, int], bytes] = field(default_factory=dict)
    truncated: int = 0

    def add(self, report: AdvertisingReport) -> AdvertisingReport | None:
        """The whole advertisement once its last part came (None until then, or if cut)."""
        key = (report.address, report.sid)
        data = self._partial.pop(key, b"") + report.data
        if report.status == STATUS_MORE:
            self._partial[key] = data
            return None
        if report.status != STATUS_COMPLETE:
            self.truncated += 1
            return None
        return AdvertisingReport(
            report.transport, report.address, report.rssi_dbm, data, report.sid
        )


def remote_id_service_data(data: bytes) -> list[tuple[int, bytes]]:
    """(message counter, F3411 bytes) of each Remote ID service data structure in ``data``."""
    found: list[tuple[int, bytes]] = []
    position = 0
    while position < len(data):
        length = data[position]
        if length == 0:
            break  # the rest is padding
        structure = data[position + 1 : position + 1 + length]
        if len(structure) < length:
            raise BluetoothError(f"AD structure at byte {position} cut short")
        if structure[0] == AD_SERVICE_DATA_16 and len(structure) >= 3:
            uuid = struct.unpack_from("<H", structure, 1)[0]
            if uuid == ODID_UUID:
                found.append(_odid_service_data(structure[3:], position))
        position += 1 + length
    return found


def _odid_service_data(value: bytes, position: int) -> tuple[int, bytes]:
    if len(value) < 2 or value[0] != ODID_APP_CODE:
        raise BluetoothError(f"Remote ID service data at byte {position}: no app code 0x0D")
    return value[1], bytes(value[2:])
