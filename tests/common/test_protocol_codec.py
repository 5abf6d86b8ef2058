"""Round trips of the ground-station protocol messages through real MAVLink bytes: equal up
to the wire's quantisation (degE7 for global positions, 1e-4 m for local ones in _INT
messages, float32 for parameters and COMMAND params)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ridsafe.common import codec
from ridsafe.common import protocol_messages as pm
from ridsafe.common.codec.protocols import GLOBAL_FRAMES

f32 = st.floats(-1e6, 1e6, allow_nan=False, width=32)
lat = st.floats(-90.0, 90.0)
lon = st.floats(-180.0, 180.0)
u8 = st.integers(0, 255)
u16 = st.integers(0, 65535)
frames = st.sampled_from([0, 1, 3, 5, 6, 7])
names = st.text(alphabet="ABCDEFGHIJKLMNOPQRSTUVWXYZ_0123456789", min_size=1, max_size=16)


def _round_trip(msg: pm.ProtocolMessage) -> pm.ProtocolMessage:
    sender, receiver = codec.MavlinkLink(1, 1), codec.MavlinkLink(255, 190)
    (got,) = receiver.feed(sender.pack_all([msg]))
    out = got.message
    assert type(out) is type(msg)
    return out


def _xy(frame: int, x: float, y: float) -> tuple[float, float]:
    """Values the _INT wire can carry in ``frame``."""
    if frame in GLOBAL_FRAMES:
        return float(np.clip(x, -90, 90)), float(np.clip(y, -180, 180))
    return float(np.clip(x, -200_000, 200_000)), float(np.clip(y, -200_000, 200_000))


# Commands whose parameters the inbound edge range-checks (codec/inbound.py): the round trip
# of any values holds for the others; for these, an impossible value is dropped, not delivered.
CHECKED_COMMANDS = (176, 400, 22, 511, 512)  # DO_SET_MODE, ARM, TAKEOFF, MSG_INTERVAL, REQUEST
unchecked_commands = u16.filter(lambda c: c not in CHECKED_COMMANDS)


@settings(max_examples=60)
@given(frame=frames, command=unchecked_commands, p=st.tuples(f32, f32, f32, f32), x=lat, y=lon,
       z=f32)  # fmt: skip
def test_command_int(frame: int, command: int, p: tuple[float, ...], x: float, y: float,
                     z: float) -> None:  # fmt: skip
    x, y = _xy(frame, x, y)
    msg = pm.CommandInt(1, 1, frame, command, 0, 1, (*p, x, y, z))  # type: ignore[arg-type]
    out = _round_trip(msg)
    assert isinstance(out, pm.CommandInt)
    assert (out.frame, out.command, out.params[:4], out.params[6]) == (
        frame, command, p, z)  # fmt: skip
    quantum = 1e-7 if frame in GLOBAL_FRAMES else 1e-4
    np.testing.assert_allclose(out.params[4:6], (x, y), atol=quantum / 2 + 1e-12)


def test_a_command_int_with_an_impossible_checked_parameter_is_dropped_and_counted() -> None:
    sender, receiver = codec.MavlinkLink(1, 1), codec.MavlinkLink(255, 190)
    base_mode_256 = pm.CommandInt(1, 1, 0, 176, 0, 1, (256.0, 4.0, 0, 0, 0, 0, 0))
    guided = pm.CommandInt(1, 1, 0, 176, 0, 1, (1.0, 4.0, 0, 0, 0, 0, 0))
    got = receiver.feed(sender.pack_all([base_mode_256, guided]))
    assert [r.message for r in got] == [guided]
    assert receiver.counters.invalid_value == 1


@settings(max_examples=60)
@given(frame=frames, seq=u16, command=u16, x=lat, y=lon, z=f32, kind=st.sampled_from([0, 1, 2]))
def test_mission_item_int(frame: int, seq: int, command: int, x: float, y: float, z: float,
                          kind: int) -> None:  # fmt: skip
    x, y = _xy(frame, x, y)
    msg = pm.MissionItemInt(1, 1, seq, frame, command, 0, 1, (0, 0, 0, 0, x, y, z), kind)
    out = _round_trip(msg)
    assert isinstance(out, pm.MissionItemInt)
    assert (out.seq, out.frame, out.command, out.mission_type, out.params[6]) == (
        seq, frame, command, kind, z)  # fmt: skip
    quantum = 1e-7 if frame in GLOBAL_FRAMES else 1e-4
    np.testing.assert_allclose(out.params[4:6], (x, y), atol=quantum / 2 + 1e-12)


@settings(max_examples=60)
@given(name=names, value=f32, count=u16, index=u16)
def test_param_value_and_set(name: str, value: float, count: int, index: int) -> None:
    assert _round_trip(pm.ParamValue(name, value, 9, count, index)) == pm.ParamValue(
        name, value, 9, count, index)  # fmt: skip
    assert _round_trip(pm.ParamSet(1, 1, name, value, 9)) == pm.ParamSet(1, 1, name, value, 9)
    read = pm.ParamRequestRead(1, 1, name, -1)
    assert _round_trip(read) == read


@settings(max_examples=40)
@given(
    la=lat,
    lo=lon,
    alt=st.floats(-1000, 10_000),
    speed=st.floats(0, 600),
    course=st.floats(0, 359.99),
)
def test_gps_raw_int(la: float, lo: float, alt: float, speed: float, course: float) -> None:
    msg = pm.GpsRawInt(12.5, 3, la, lo, alt, 0.8, 1.2, speed, course, 10)
    out = _round_trip(msg)
    assert isinstance(out, pm.GpsRawInt)
    assert (out.lat_deg, out.lon_deg) == pytest.approx((la, lo), abs=0.5e-7)
    assert out.alt_msl_m == pytest.approx(alt, abs=0.5e-3)
    half_cm = 0.005 + 1e-9  # half the wire's 1 cm/s (cdeg) step, and the float error of x/100
    assert out.ground_speed_m_s == pytest.approx(speed, abs=half_cm)
    assert out.course_deg == pytest.approx(course, abs=half_cm) or course > 359.99


@pytest.mark.parametrize(
    "msg",
    [
        pm.ParamRequestList(1, 1),
        pm.MissionRequestList(1, 1, 1),
        pm.MissionCount(255, 190, 7, 2),
        pm.MissionRequestInt(255, 190, 3, 0),
        pm.MissionRequest(1, 1, 3, 0),
        pm.MissionAck(255, 190, 13, 0),
        pm.MissionClearAll(1, 1, 255),
        pm.MissionSetCurrent(1, 1, 2),
        pm.MissionCurrent(2, 5),
        pm.MissionItemReached(4),
        pm.Timesync(0, 123456789),
        pm.RequestDataStream(1, 1, 6, 4, True),
        pm.ExtendedSysState(0, 2),
        pm.AutopilotVersion(0xE1CF, 0x04070000, 0, 0, 0, 1),
        pm.BatteryStatus(25.2, 1.5, 80),
        pm.VfrHud(3.0, 3.0, 270, 50, 230.5, -0.5),
        pm.RcChannels(1.5, 16, (1500,) * 16 + (0, 0), 255),
    ],
)
def test_exact_round_trips(msg: pm.ProtocolMessage) -> None:
    assert _round_trip(msg) == msg
