"""The aircraft as its autopilot reports it: the receiver's position at a receive time, the
autopilot clock estimate, UNIX time and the local frame about home.

Oracle for extrapolation: ``frames.ned_to_geodetic`` (the exact ECEF-based conversion) against
the radii-of-curvature formula.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ridsafe.common import frames
from ridsafe.common import messages as m
from ridsafe.companion.telemetry import OwnTelemetry, ReceiverFix


@settings(max_examples=100)
@given(
    lat=st.floats(-80.0, 80.0),
    lon=st.floats(-180.0, 180.0),
    alt=st.floats(-100.0, 3000.0),
    v=st.tuples(st.floats(-10.0, 10.0), st.floats(-10.0, 10.0), st.floats(-5.0, 5.0)),
    dt=st.floats(-0.5, 0.5),
)
def test_extrapolation_matches_the_exact_ned_to_geodetic_conversion(
    lat: float, lon: float, alt: float, v: tuple[float, float, float], dt: float
) -> None:
    fix = ReceiverFix(10.0, lat, lon, alt, v)
    got = fix.at(10.0 + dt, max_extrapolation_s=1.0)
    origin = frames.GeodeticOrigin(lat, lon, alt)
    exact = frames.ned_to_geodetic(origin, np.array(v) * dt)
    back = frames.geodetic_to_ned(origin, *got)
    expected = frames.geodetic_to_ned(origin, *(float(x) for x in exact))
    assert np.linalg.norm(back - expected) < 1e-3


def test_extrapolation_is_bounded() -> None:
    fix = ReceiverFix(0.0, 36.0, -86.0, 200.0, (0.0, 0.0, -2.0))
    assert fix.at(100.0, max_extrapolation_s=1.0)[2] == 202.0
    assert fix.at(0.0, max_extrapolation_s=1.0) == (36.0, -86.0, 200.0)


# --- own telemetry: clock, UNIX time, frames ---------------------------------------------------


def test_the_autopilot_clock_estimate_takes_the_least_delayed_sample_and_follows_a_reboot() -> None:
    own = OwnTelemetry()
    assert own.sim_time(3.0) == 3.0  # nothing heard yet
    own.observe_clock(10.0, 7.95)  # 50 ms on the way
    own.observe_clock(10.1, 8.09)  # 10 ms
    own.observe_clock(10.2, 8.13)  # 70 ms
    assert own.sim_time(11.0) == pytest.approx(8.99)
    own.observe_clock(20.0, 0.5)  # boot time restarted
    assert own.sim_time(21.0) == pytest.approx(1.5)


def test_unix_time_advances_from_system_time() -> None:
    own = OwnTelemetry()
    assert own.unix_s(1.0) is None
    own.system_time, own.system_time_s = m.SystemTime(1_767_268_800.0, 4.0), 4.02
    assert own.unix_s(6.52) == pytest.approx(1_767_268_802.5)
    own.system_time = m.SystemTime(0.0, 4.0)  # an autopilot without GPS time
    assert own.unix_s(6.52) is None


def test_local_frame_is_about_home_shifted_by_homes_local_position() -> None:
    own = OwnTelemetry()
    with pytest.raises(LookupError):
        own.to_local(36.0, -86.0, 200.0)
    # ArduPilot: LOCAL_POSITION_NED is about the EKF origin; home sits at (x, y, z) in it
    own.set_home(m.HomePosition(36.1447, -86.8027, 180.0, (12.0, -7.0, 1.5)))
    assert own.to_local(36.1447, -86.8027, 180.0) == pytest.approx((12.0, -7.0, 1.5))
    origin = frames.GeodeticOrigin(36.1447, -86.8027, 180.0)
    lat, lon, alt = frames.ned_to_geodetic(origin, np.array([300.0, -200.0, -50.0]))
    assert own.to_local(float(lat), float(lon), float(alt)) == pytest.approx(
        (312.0, -207.0, -48.5), abs=1e-6
    )
    back = own.to_geodetic((312.0, -207.0, -48.5))
    assert back == pytest.approx((float(lat), float(lon), float(alt)), abs=1e-9)
