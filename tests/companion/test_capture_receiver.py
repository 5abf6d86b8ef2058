"""A companion fed by a capture of real receivers reports what one fed by the sim reports.

Oracle: the same flight twice. First the companion of aircraft 1 hears the sim's radio
through its transponder link (RIDSAFE_RID_FRAME), and every frame it heard is kept with its
arrival time and RSSI (whole dBm: ``rssi_resolution_db=1``, as real receivers report). Those
frames are then written into a capture exactly as the transports carry them (Wi-Fi: beacons
with the F3411 vendor element and NAN frames, pcap/pcapng with radiotap; Bluetooth: single
messages as legacy advertising reports, packs as extended ones, btsnoop), each at its arrival
time after a first non-Remote-ID record at time 0. The second flight's companion hears only
that capture (``CaptureReceiver``); the observations both send to the GCS must be equal, field
for field, as decoded from the MAVLink bytes.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import pytest

from ridsafe.common import f3411
from ridsafe.common import messages as m
from ridsafe.common.capture import read_capture_file
from ridsafe.common.heard import HeardRidFrame
from ridsafe.common.scenario import RadioConfig, Scenario
from ridsafe.companion.mission import Phase
from ridsafe.companion.receivers import CaptureReceiver, TransponderReceiver
from tests.common.capture import builders as b
from tests.companion.test_companion_core import AIRCRAFT, ORIGIN, Flight

FLIGHT_S = 12.0


class TapReceiver(TransponderReceiver):
    """The transponder receiver, keeping every frame it hands the companion."""

    def __init__(self) -> None:
        super().__init__()
        self.heard: list[HeardRidFrame] = []

    def poll(self, now_s: float) -> list[HeardRidFrame]:
        out = super().poll(now_s)
        self.heard.extend(out)
        return out


def _scenario() -> Scenario:
    radio = RadioConfig(shadowing_sigma_db=4.0, rssi_resolution_db=1.0)
    return Scenario(ORIGIN, AIRCRAFT[:3], None, radio, seed=11)


def _observations(flight: Flight) -> list[m.Observation]:
    received = [r.message for r in flight.gcs_received(1)]
    return [o for r in received if isinstance(r, m.ObservationRows) for o in r.observations()]


def _mac(sender_id: bytes, macs: dict[bytes, str]) -> str:
    return macs.setdefault(sender_id, f"02:00:00:00:00:{len(macs) + 1:02x}")


def _as_pack(frame: bytes) -> bytes:
    is_pack = f3411.message_type(frame) is f3411.MessageType.MESSAGE_PACK
    return frame if is_pack else f3411.pack([frame])


def _wifi_packets(heard: Sequence[HeardRidFrame]) -> list[b.Timed]:
    """Even frames as beacons, odd ones as NAN (both carry message packs)."""
    macs: dict[bytes, str] = {}
    items = [b.Timed(0.0, b.plain_beacon("00:11:22:33:44:55", -40))]
    for index, frame in enumerate(heard):
        mac, dbm, pack = _mac(frame.sender_id, macs), int(frame.rssi_dbm), _as_pack(frame.frame)
        build = b.beacon if index % 2 == 0 else b.nan_frame
        items.append(b.Timed(frame.rx_t_s, build(mac, index % 256, pack, dbm)))
    return items


def _bluetooth_packets(heard: Sequence[HeardRidFrame]) -> list[b.Timed]:
    """Single messages as legacy advertising, packs as extended (Bluetooth 5)."""
    macs: dict[bytes, str] = {}
    items = [b.Timed(0.0, b.plain_advert_event("c0:ff:ee:00:00:01", -30))]
    for index, frame in enumerate(heard):
        mac, dbm, counter = _mac(frame.sender_id, macs), int(frame.rssi_dbm), index % 256
        if len(frame.frame) == f3411.MESSAGE_SIZE:
            event = b.legacy_report_event(mac, counter, frame.frame, dbm)
        else:
            data = bytes(b.odid_service_data(counter, frame.frame))
            event = b.extended_report_event(mac, data, dbm)
        items.append(b.Timed(frame.rx_t_s, event))
    return items


Writer = Callable[[Path, Sequence[HeardRidFrame]], Path]
WRITERS: dict[str, Writer] = {
    "wifi-pcap": lambda p, h: b.write_pcap(p, _wifi_packets(h), b.LINKTYPE_RADIOTAP),
    "wifi-pcapng": lambda p, h: b.write_pcapng(p, _wifi_packets(h), b.LINKTYPE_RADIOTAP),
    "ble-btsnoop": lambda p, h: b.write_btsnoop(p, _bluetooth_packets(h)),
}


@pytest.fixture(scope="module")
def sim_fed() -> tuple[list[HeardRidFrame], list[m.Observation]]:
    flight = Flight(_scenario())
    tap = TapReceiver()
    flight.companions[1].receiver = tap
    flight.run(FLIGHT_S)
    return tap.heard, _observations(flight)


@pytest.mark.parametrize("kind", sorted(WRITERS))
def test_a_capture_of_the_same_frames_gives_the_same_observations(
    kind: str, sim_fed: tuple[list[HeardRidFrame], list[m.Observation]], tmp_path: Path
) -> None:
    heard, expected = sim_fed
    assert len(expected) >= 10 and all(h.rssi_dbm == int(h.rssi_dbm) for h in heard)
    capture = read_capture_file(WRITERS[kind](tmp_path / f"rid.{kind}", heard))
    assert not capture.skipped and len(capture.frames) == len(heard)

    flight = Flight(_scenario())
    receiver = CaptureReceiver(capture)
    flight.companions[1].receiver = receiver
    flight.run(FLIGHT_S)

    assert _observations(flight) == expected
    assert receiver.counters()["released"] == len(heard)


def test_a_damaged_capture_is_counted_and_the_companion_flies_on(tmp_path: Path) -> None:
    garbage = bytes([0x1F]) + bytes(range(24))  # type 1, version 15: not a readable LOCATION
    location = b.reference_messages("OPEN_DRONE_ID_LOCATION", 1)[0]
    items = [
        b.Timed(0.5, b.legacy_report_event("c0:00:00:00:00:07", 2, garbage, -70)),
        b.Timed(1.0, b.legacy_report_event("c0:00:00:00:00:07", 3, location, -71)),
    ]
    path = b.write_btsnoop(tmp_path / "bad.btsnoop", items)
    path.write_bytes(path.read_bytes()[:-7])  # the last record cut short
    capture = read_capture_file(path)
    assert len(capture.frames) == 1 and capture.skipped == {"truncated": 1}

    flight = Flight(_scenario())
    receiver = CaptureReceiver(capture, start_s=2.0)
    flight.companions[1].receiver = receiver
    flight.run(4.0)
    counters = flight.companions[1].counters_snapshot()
    assert counters["receiver.released"] == 1 and counters["receiver.skipped_truncated"] == 1
    assert counters["observations.frame_errors"] == 1
    assert flight.companions[1].phase is not Phase.FAILED
