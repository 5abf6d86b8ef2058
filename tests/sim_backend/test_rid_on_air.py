"""Remote ID on the air: F3411 quantisation between two transponders, and the whole sim backend
carrying the spoofer's lie to a benign aircraft's companion, in one RIDSAFE_RID_FRAME per
frame heard with the RSSI of the truth.

Oracles: the F3411 quantisation steps (1e-7 deg rounded, 0.5 m altitude and 0.5 m/s vertical
speed truncated toward zero, 0.25 m/s ground speed and whole degrees rounded, 0.1 s) applied to
random states (Hypothesis); in the integration test, truth from ``SimBackend.truth()`` and the
free-space equation re-derived here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from ridsafe.common import codec, frames, rid
from ridsafe.common import messages as m
from ridsafe.common.dialect import ridsafe_v20 as mav
from ridsafe.common.heard import decode_rid_frame
from ridsafe.common.scenario import AircraftConfig, RadioConfig, Scenario, SpooferConfig
from ridsafe.sim_backend.transponder import Transponder
from ridsafe.sim_backend.world import SimBackend, Truth

SENDER_ID = b"RSAF800000001"

# --- quantisation on the air -----------------------------------------------------------------


def _circular_diff_deg(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


@settings(max_examples=200)
@given(
    lat=st.floats(-90.0, 90.0),
    lon=st.floats(-180.0, 180.0),
    alt=st.floats(-900.0, 10_000.0),
    height=st.floats(-500.0, 5_000.0),
    vn=st.floats(-40.0, 40.0),
    ve=st.floats(-40.0, 40.0),  # ground speed <= 56.6 m/s: the 0.25 m/s scale (< 63.75)
    vd=st.floats(-60.0, 60.0),
    unix_s=st.floats(1.6e9, 2.0e9),
    airborne=st.booleans(),
    emergency=st.booleans(),
)
def test_a_location_survives_the_air_within_f3411_quantisation(
    lat: float,
    lon: float,
    alt: float,
    height: float,
    vn: float,
    ve: float,
    vd: float,
    unix_s: float,
    airborne: bool,
    emergency: bool,
) -> None:
    # latitude and longitude both 0 degE7 mean "unknown" in MAVLink
    assume(round(lat * 1e7) != 0 or round(lon * 1e7) != 0)
    state = rid.OwnState(unix_s, lat, lon, alt, height, (vn, ve, vd), airborne, emergency)
    sent = rid.location(state)
    frame = Transponder(1, SENDER_ID).on_message(0.0, sent)
    assert frame is not None
    receiver = Transponder(2, b"RSAF800000002")
    report = receiver.report(frame, SENDER_ID, -77.5)
    assert report == m.RidFrameReport(frame, -77.5, SENDER_ID, int(m.RidTransport.SIMULATED))
    (got,) = decode_rid_frame(report.frame, report.sender_id).locations()
    assert got.id_or_mac == SENDER_ID
    assert got.status == sent.status

    # lat/lon: degE7, rounded
    assert got.lat_deg is not None and got.lon_deg is not None
    assert abs(got.lat_deg - lat) <= 0.5e-7 + 1e-12
    assert abs(got.lon_deg - lon) <= 0.5e-7 + 1e-12
    # altitudes: 0.5 m steps above -1000 m, truncated (never above what was sent);
    # 1e-3 m of slack for the float32 the MAVLink field holds
    assert got.alt_geodetic_m is not None and got.height_m is not None
    assert -1e-3 <= alt - got.alt_geodetic_m < 0.5 + 1e-3
    assert -1e-3 <= height - got.height_m < 0.5 + 1e-3
    assert got.alt_baro_m is None
    # ground speed: cm/s, then 0.25 m/s steps rounded
    speed = math.hypot(vn, ve)
    assert got.speed_horizontal_m_s is not None
    assert abs(got.speed_horizontal_m_s - speed) <= 0.125 + 0.005 + 1e-6
    # vertical speed (up positive): cm/s, then 0.5 m/s steps truncated toward zero
    assert got.speed_vertical_m_s is not None
    assert abs(got.speed_vertical_m_s - (-vd)) < 0.5
    assert abs(got.speed_vertical_m_s) <= abs(vd) + 0.005
    # course: cdeg, then whole degrees rounded
    if sent.course_deg is None:
        assert got.course_deg is None
    else:
        assert got.course_deg is not None
        assert _circular_diff_deg(got.course_deg, sent.course_deg) <= 0.5 + 0.005 + 1e-9
    # timestamp: seconds after the hour in 0.1 s
    assert got.timestamp_s is not None and sent.timestamp_s is not None
    assert abs(got.timestamp_s - sent.timestamp_s) <= 1e-3
    assert abs(got.timestamp_s - math.fmod(unix_s, 3600.0)) <= 0.05 + 1e-3


# --- the sim backend end to end --------------------------------------------------------------

ORIGIN = frames.GeodeticOrigin(47.3769, 8.5417, 408.0)
OFFSET_ENU_M = (50.0, 50.0, 0.0)
SPOOFER_SERIAL = "RSAF800000009"
TICK_S = 0.02
DURATION_S = 3.5


def _scenario() -> Scenario:
    aircraft = (
        AircraftConfig("RSAF800000001", (100.0, 0.0, 0.0), (100.0, 600.0, 0.0)),
        AircraftConfig("RSAF800000002", (-150.0, 80.0, 0.0), (-150.0, 600.0, 0.0)),
        AircraftConfig("RSAF800000003", (60.0, -220.0, 0.0), (600.0, -220.0, 0.0)),
    )
    spoofer = SpooferConfig(
        SPOOFER_SERIAL, (0.0, 200.0, 40.0), (600.0, 200.0, 40.0), 7.0, OFFSET_ENU_M
    )
    return Scenario(ORIGIN, aircraft, spoofer, RadioConfig(shadowing_sigma_db=0.0), seed=3)


@dataclass(frozen=True)
class Heard:
    """One message on vehicle 1's companion link, with the truth of the tick it came in."""

    t_s: float
    src_component: int
    message: m.Message
    truth: Truth


@pytest.fixture(scope="module")
def heard_by_vehicle_1() -> list[Heard]:
    backend = SimBackend(_scenario())
    link = codec.MavlinkLink(255, 190)
    heard: list[Heard] = []
    for k in range(round(DURATION_S / TICK_S) + 1):
        t = k * TICK_S
        out = backend.handle(t, [])
        truth = backend.truth()
        for name, data in out:
            if name == "v1/companion":
                heard += [Heard(t, r.src_component, r.message, truth) for r in link.feed(data)]
    assert link.counters.dropped == 0
    return heard


def fspl_dbm(pt_dbm: float, d_m: float, f_mhz: float = 2400.0) -> float:
    """The paper's eq. (8): Pr = Pt - 20 log10(d_km) - 20 log10(f_MHz) - 32.44."""
    return pt_dbm - 20.0 * math.log10(d_m / 1000.0) - 20.0 * math.log10(f_mhz) - 32.44


def _spoofer_frames(heard: list[Heard], msg_type: m.OdidMessageType) -> list[Heard]:
    """Every heard frame of the spoofer of F3411 type ``msg_type``."""
    out = []
    for item in heard:
        report = item.message
        if (
            isinstance(report, m.RidFrameReport)
            and report.sender_id == SPOOFER_SERIAL.encode()
            and report.frame[0] >> 4 == msg_type
        ):
            out.append(item)
    return out


def _location(item: Heard) -> m.OdidLocation:
    assert isinstance(item.message, m.RidFrameReport)
    (loc,) = decode_rid_frame(item.message.frame, item.message.sender_id).locations()
    return loc


def test_vehicle_1_hears_the_spoofers_claim_of_truth_plus_offset(
    heard_by_vehicle_1: list[Heard],
) -> None:
    frames_heard = _spoofer_frames(heard_by_vehicle_1, m.OdidMessageType.LOCATION)
    assert len(frames_heard) >= 3  # 1 Hz for 3.5 s, whatever the phase
    for item in frames_heard:
        loc = _location(item)
        assert item.src_component == 236
        assert loc.lat_deg is not None and loc.lon_deg is not None
        assert loc.alt_geodetic_m is not None
        claimed = frames.geodetic_to_enu(ORIGIN, loc.lat_deg, loc.lon_deg, loc.alt_geodetic_m)
        truth = item.truth.p_enu_m[3]
        expected = truth + np.array(OFFSET_ENU_M)
        assert np.hypot(*(claimed[:2] - expected[:2])) <= 0.02  # 1e-7 deg on the air
        assert abs(claimed[2] - expected[2]) <= 0.5 + 1e-3  # 0.5 m altitude steps
        assert np.linalg.norm(claimed - truth) > 70.0  # the lie, not the truth
        assert item.truth.spoofer_claimed_p_enu_m is not None
        np.testing.assert_allclose(item.truth.spoofer_claimed_p_enu_m, expected)
        # flying east at 7 m/s: whole degrees and 0.25 m/s on the air
        assert loc.course_deg == 90.0
        assert loc.speed_horizontal_m_s == pytest.approx(7.0, abs=0.13)
        assert loc.status == int(m.OdidStatus.AIRBORNE)


def test_each_location_frame_carries_the_rssi_of_the_true_position(
    heard_by_vehicle_1: list[Heard],
) -> None:
    frames_heard = _spoofer_frames(heard_by_vehicle_1, m.OdidMessageType.LOCATION)
    assert frames_heard
    for item in frames_heard:
        rssi = item.message
        assert isinstance(rssi, m.RidFrameReport)
        assert rssi.transport == int(m.RidTransport.SIMULATED)
        rx = item.truth.p_enu_m[0]
        true_d = float(np.linalg.norm(item.truth.p_enu_m[3] - rx))
        assert rssi.rssi_dbm == pytest.approx(fspl_dbm(20.0, true_d), abs=0.01)
        assert item.truth.spoofer_claimed_p_enu_m is not None
        claimed_d = float(np.linalg.norm(item.truth.spoofer_claimed_p_enu_m - rx))
        assert abs(rssi.rssi_dbm - fspl_dbm(20.0, claimed_d)) > 0.5  # tells them apart


def test_the_spoofers_static_messages_arrive_in_a_pack_with_one_rssi(
    heard_by_vehicle_1: list[Heard],
) -> None:
    packs = _spoofer_frames(heard_by_vehicle_1, m.OdidMessageType.MESSAGE_PACK)
    assert packs
    for item in packs:
        report = item.message
        assert isinstance(report, m.RidFrameReport) and math.isfinite(report.rssi_dbm)
        contents = decode_rid_frame(report.frame, report.sender_id)
        assert not contents.errors
        inside = contents.messages
        basic = [msg for msg in inside if isinstance(msg, m.OdidBasicId)]
        assert len(basic) == 1 and basic[0].uas_id_str == SPOOFER_SERIAL
        assert all(getattr(msg, "id_or_mac", None) == SPOOFER_SERIAL.encode() for msg in inside)
        assert any(isinstance(msg, m.OdidSystem) for msg in inside)
        assert any(isinstance(msg, m.OdidOperatorId) for msg in inside)


def test_autopilot_and_transponder_heartbeats_arrive(heard_by_vehicle_1: list[Heard]) -> None:
    beats = [
        (h.src_component, h.message)
        for h in heard_by_vehicle_1
        if isinstance(h.message, m.Heartbeat)
    ]
    autopilot = [hb for component, hb in beats if component == 1]
    transponder = [hb for component, hb in beats if component == 236]
    assert len(autopilot) >= 3 and len(transponder) >= 3  # 1 Hz for 3.5 s
    assert all(hb.mav_type == 14 and hb.autopilot == 3 for hb in autopilot)  # ArduCopter octo
    assert all(hb.mav_type == 34 for hb in transponder)  # MAV_TYPE_ODID
    assert {component for component, _ in beats} == {1, 236}


def _companion_packet(message: m.Message) -> bytes:
    return codec.MavlinkLink(1, 191).pack(message)


def test_a_companions_location_reaches_the_other_companions() -> None:
    backend = SimBackend(_scenario())
    state = rid.OwnState(1_767_268_800.5, 47.3771, 8.5431, 408.0, 0.0, (0.0, 0.0, 0.0), False)
    sent = _companion_packet(rid.location(state))
    out = backend.handle(0.02, [("v1/companion", sent)])
    v2 = codec.MavlinkLink(255, 190)
    received = [r.message for name, data in out if name == "v2/companion" for r in v2.feed(data)]
    reports = [msg for msg in received if isinstance(msg, m.RidFrameReport)]
    assert len(reports) == 1
    locations = decode_rid_frame(reports[0].frame, reports[0].sender_id).locations()
    assert len(locations) == 1
    assert locations[0].id_or_mac == b"RSAF800000001"
    assert locations[0].lat_deg == pytest.approx(47.3771, abs=1e-7)
    assert locations[0].status == int(m.OdidStatus.GROUND)
    assert backend.transponders[0].counters.sent == 1


def test_a_non_ascii_operator_id_from_a_companion_does_not_stop_the_sim() -> None:
    backend = SimBackend(_scenario())
    raw = mav.MAVLink_open_drone_id_operator_id_message(0, 0, [0] * 20, 0, b"OP\xff")
    data = bytes(raw.pack(mav.MAVLink(None, srcSystem=1, srcComponent=191)))
    backend.handle(0.02, [("v1/companion", data)])
    assert backend.transponders[0].counters.encode_rejected == 1
