"""Captures built around real F3411 bytes, as the transports specify, for the capture tests.

Wi-Fi frames and Bluetooth HCI events are built with scapy (RadioTap / Dot11 / Dot11Beacon /
Dot11Elt / Dot11EltVendorSpecific, HCI_Hdr / HCI_Event_LE_Meta / advertising reports /
EIR_ServiceData16BitUUID) and written with scapy's PcapWriter / PcapNgWriter. Two pieces are
written by hand here, from the specifications, because scapy has no layer for them: the NAN
service discovery body (public action, Wi-Fi Alliance OUI, NAN attributes) and the btsnoop
file format (scapy reads no btsnoop and writes none).
"""

from __future__ import annotations

import gzip
import json
import struct
from collections.abc import Sequence
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path

from scapy.layers.bluetooth import (
    EIR_Hdr,
    EIR_ServiceData16BitUUID,
    HCI_Event_Hdr,
    HCI_Event_LE_Meta,
    HCI_Hdr,
    HCI_LE_Meta_Advertising_Report,
    HCI_LE_Meta_Advertising_Reports,
    HCI_LE_Meta_Extended_Advertising_Report,
    HCI_LE_Meta_Extended_Advertising_Reports,
)
from scapy.layers.dot11 import (
    Dot11,
    Dot11Beacon,
    Dot11Elt,
    Dot11EltVendorSpecific,
    RadioTap,
)
from scapy.packet import Packet, Raw
from scapy.utils import PcapNgWriter, PcapWriter

from ridsafe.common import f3411
from ridsafe.common.capture.containers import BTSNOOP_EPOCH_OFFSET_US

VECTORS_PATH = Path(__file__).parents[2] / "data" / "odid_f3411_vectors.jsonl.gz"
EPOCH_S = 1_700_000_000  # capture times start here (Unix seconds)
LINKTYPE_RADIOTAP, LINKTYPE_H4 = 127, 187
NAN_SERVICE_ID = bytes.fromhex("8869199d9209")  # "org.opendroneid.remoteid", as the spec lists it


def reference_messages(kind: str, count: int) -> list[bytes]:
    """``count`` reference encodings of message ``kind`` (e.g. OPEN_DRONE_ID_LOCATION)."""
    found: list[bytes] = []
    with gzip.open(VECTORS_PATH, "rt", encoding="utf-8") as lines:
        for line in lines:
            case = json.loads(line)
            if case["message"] == kind and case["f3411_hex"]:
                found.append(bytes.fromhex(case["f3411_hex"]))
                if len(found) == count:
                    break
    return found


def mac_bytes(mac: str) -> bytes:
    return bytes.fromhex(mac.replace(":", ""))


# -- Wi-Fi -------------------------------------------------------------------------------


def radiotap(dbm: int, frequency_mhz: int = 2437, fcs: bool = False) -> Packet:
    flags = "FCS" if fcs else 0
    return RadioTap(
        present="Flags+Channel+dBm_AntSignal", Flags=flags, ChannelFrequency=frequency_mhz,
        ChannelFlags="2GHz+CCK", dBm_AntSignal=dbm,
    )  # fmt: skip


def beacon(mac: str, counter: int, pack: bytes, dbm: int, fcs: bool = False) -> Packet:
    """A beacon with the Remote ID vendor element: OUI FA-0B-BC, type 0x0D, counter, pack."""
    element = Dot11EltVendorSpecific(oui=0xFA0BBC, info=bytes([0x0D, counter]) + pack)
    frame = (
        radiotap(dbm, fcs=fcs)
        / Dot11(type=0, subtype=8, addr1="ff:ff:ff:ff:ff:ff", addr2=mac, addr3=mac)
        / Dot11Beacon(cap="short-slot+short-preamble")
        / Dot11Elt(ID="SSID", info=b"RID-1")
        / element
    )
    if fcs:
        return RadioTap(bytes(frame) + struct.pack("<I", 0xDEADBEEF))  # FCS value not checked
    return frame


def nan_body(counter: int, pack: bytes, service_control: int = 0x10) -> bytes:
    """NAN service discovery body (by hand): public action 4 / vendor 9, OUI 50-6F-9A type
    0x13, a Service Descriptor attribute (id 3) with the Remote ID service id and service
    info (counter + pack), then the Service Descriptor Extension attribute (id 0x0E)."""
    info = bytes([counter]) + pack
    optional = b""
    if service_control & 0x40:
        optional += b"\x00\x00"  # binding bitmap
    if service_control & 0x04:
        optional += b"\x02\xaa\xbb"  # matching filter of 2 bytes
    descriptor = NAN_SERVICE_ID + bytes([1, 0, service_control]) + optional
    descriptor += bytes([len(info)]) + info
    extension = bytes([1]) + struct.pack("<H", 0x0200) + bytes([counter])
    return (
        bytes([4, 9]) + bytes.fromhex("506f9a") + bytes([0x13])
        + bytes([3]) + struct.pack("<H", len(descriptor)) + descriptor
        + bytes([0x0E]) + struct.pack("<H", len(extension)) + extension
    )  # fmt: skip


def nan_frame(mac: str, counter: int, pack: bytes, dbm: int, service_control: int = 0x10) -> Packet:
    return (
        radiotap(dbm, frequency_mhz=2437)
        / Dot11(type=0, subtype=13, addr1="51:6f:9a:01:00:00", addr2=mac, addr3="50:6f:9a:01:00:00")
        / Raw(nan_body(counter, pack, service_control))
    )


def plain_beacon(mac: str, dbm: int) -> Packet:
    """A beacon without Remote ID (an access point nearby)."""
    return (
        radiotap(dbm)
        / Dot11(type=0, subtype=8, addr1="ff:ff:ff:ff:ff:ff", addr2=mac, addr3=mac)
        / Dot11Beacon()
        / Dot11Elt(ID="SSID", info=b"cafe")
    )


# -- Bluetooth ---------------------------------------------------------------------------


def odid_service_data(counter: int, frame: bytes) -> Packet:
    """AD structure: service data, UUID 0xFFFA, app code 0x0D, counter, F3411 bytes."""
    body = EIR_ServiceData16BitUUID(svc_uuid=0xFFFA) / Raw(bytes([0x0D, counter]) + frame)
    return EIR_Hdr(type=0x16) / body


def legacy_report_event(address: str, counter: int, message: bytes, dbm: int) -> Packet:
    report = HCI_LE_Meta_Advertising_Report(
        type=3, addr_type=1, addr=address, data=[odid_service_data(counter, message)], rssi=dbm
    )
    return (
        HCI_Hdr()
        / HCI_Event_Hdr()
        / HCI_Event_LE_Meta()
        / HCI_LE_Meta_Advertising_Reports(reports=[report])
    )


def plain_advert_event(address: str, dbm: int) -> Packet:
    """A legacy advertisement without Remote ID (an Eddystone beacon nearby: UUID 0xFEAA)."""
    data = EIR_Hdr(type=0x16) / EIR_ServiceData16BitUUID(svc_uuid=0xFEAA) / Raw(b"\x10\x00")
    report = HCI_LE_Meta_Advertising_Report(
        type=3, addr_type=1, addr=address, data=[data], rssi=dbm
    )
    return (
        HCI_Hdr()
        / HCI_Event_Hdr()
        / HCI_Event_LE_Meta()
        / HCI_LE_Meta_Advertising_Reports(reports=[report])
    )


def extended_report_event(
    address: str, data: bytes, dbm: int, data_status: int = 0, sid: int = 1
) -> Packet:
    report = HCI_LE_Meta_Extended_Advertising_Report(
        data_status=data_status, legacy=0, addr_type=1, addr=address, primary_phy=3,
        secondary_phy=3, advertising_sid=sid, tx_power=10, rssi=dbm, data=Raw(data),
    )  # fmt: skip
    return (
        HCI_Hdr()
        / HCI_Event_Hdr()
        / HCI_Event_LE_Meta()
        / HCI_LE_Meta_Extended_Advertising_Reports(reports=[report])
    )


# -- files -------------------------------------------------------------------------------


@dataclass(frozen=True)
class Timed:
    t_s: float  # seconds after EPOCH_S
    packet: Packet | bytes


def _set_time(item: Timed) -> Packet:
    packet = item.packet if isinstance(item.packet, Packet) else Raw(item.packet)
    packet.time = Decimal(EPOCH_S) + Decimal(repr(item.t_s))  # exact to the digit
    return packet


def write_pcap(path: Path, items: Sequence[Timed], linktype: int, nano: bool = False) -> Path:
    with PcapWriter(str(path), linktype=linktype, nano=nano, sync=True) as writer:
        for item in items:
            writer.write(_set_time(item))
    return path


def write_pcapng(path: Path, items: Sequence[Timed], linktype: int) -> Path:
    with PcapNgWriter(str(path)) as writer:
        writer.linktype = linktype
        for item in items:
            writer.write(_set_time(item))
    return path


BTSNOOP_H4, BTSNOOP_MONITOR = 1002, 2001
MONITOR_EVENT_FLAGS = 0x0000_0003  # adapter 0, opcode 3 (event)


def write_btsnoop(path: Path, items: Sequence[Timed], datalink: int = BTSNOOP_H4) -> Path:
    """btsnoop by hand: "btsnoop\\0", version 1, datalink; records big-endian (original
    length, included length, flags, drops, timestamp in us since 0000-01-01)."""
    out = bytearray(b"btsnoop\x00" + struct.pack(">II", 1, datalink))
    for item in items:
        data = bytes(item.packet)
        flags = 0x3  # received event (H4 / unencapsulated meaning)
        if datalink == BTSNOOP_MONITOR:
            data, flags = data[1:], MONITOR_EVENT_FLAGS  # the monitor format has no H4 byte
        t_us = round((EPOCH_S + item.t_s) * 1e6) + BTSNOOP_EPOCH_OFFSET_US
        out += struct.pack(">IIIIq", len(data), len(data), flags, 0, t_us) + data
    path.write_bytes(bytes(out))
    return path


def location_pack(location: bytes, basic_id: bytes | None = None) -> bytes:
    return f3411.pack([basic_id, location] if basic_id is not None else [location])
