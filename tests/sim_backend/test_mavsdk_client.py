"""MAVSDK-Python (native, bundling its C++ core) against ``ridsafe sim`` over real UDP: the
steps a MAVSDK app takes with an ArduCopter, each of which must succeed."""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import pytest

from tests.sim_backend.udp_sim import height_m, north_east_m, sim_on_udp

mavsdk = pytest.importorskip("mavsdk", reason="MAVSDK-Python is a [test] extra")
from mavsdk.plugins.action.action import Action  # noqa: E402
from mavsdk.plugins.info.info import Info  # noqa: E402
from mavsdk.plugins.param.param import Param  # noqa: E402
from mavsdk.plugins.telemetry.telemetry import LandedState, Telemetry  # noqa: E402

GCS_BASE = 26550
COMPANION_BASE = 27760


def _until(predicate: Callable[[], bool], timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(0.1)


@pytest.mark.udp
@pytest.mark.slow
def test_mavsdk_flies_the_sim_like_an_arducopter() -> None:
    with sim_on_udp(GCS_BASE, COMPANION_BASE, speed=2.0) as backend:
        sdk = mavsdk.Mavsdk(mavsdk.Configuration.create_with_component_type(
            mavsdk.ComponentType.GROUND_STATION))  # fmt: skip
        try:
            assert sdk.add_any_connection(f"udpin://127.0.0.1:{GCS_BASE}") == 0  # SUCCESS
            system = sdk.first_autopilot(10.0)
            assert system is not None
            info, param = Info(system), Param(system)
            action, telemetry = Action(system), Telemetry(system)

            version = info.get_version()
            assert (version.flight_sw_major, version.flight_sw_minor) == (4, 7)
            assert param.get_param_int("ARMING_CHECK") == 1
            assert param.get_param_float("RTL_ALT") == 1500.0
            _until(lambda: telemetry.health().is_armable, 10.0, "is_armable")
            _until(lambda: telemetry.landed_state() == LandedState.ON_GROUND, 5.0, "on ground")
            telemetry.set_rate_gps_info(2.0)
            _until(lambda: telemetry.gps_info().num_satellites >= 6, 5.0, "a GPS fix")
            assert int(telemetry.gps_info().fix_type) >= 3

            action.arm()
            action.set_takeoff_altitude(10.0)
            action.takeoff()
            _until(lambda: height_m(backend) > 9.0, 30.0, "take-off to 10 m")
            _until(telemetry.in_air, 5.0, "in_air")
            assert telemetry.landed_state() in (LandedState.IN_AIR, LandedState.TAKING_OFF)

            here = telemetry.position()
            north_deg = 30.0 / 111_000.0  # 30 m north
            action.goto_location(here.latitude_deg + north_deg, here.longitude_deg,
                                 here.absolute_altitude_m, math.nan)  # fmt: skip
            _until(lambda: north_east_m(backend)[0] > 28.0, 30.0, "goto_location 30 m north")

            action.land()
            _until(lambda: not telemetry.armed(), 90.0, "landed and disarmed")
            assert height_m(backend) < 0.3
            assert telemetry.landed_state() == LandedState.ON_GROUND
            # Left in LAND (not armable on ArduCopter): MAVSDK changes mode and arms again.
            action.arm()
            _until(telemetry.armed, 10.0, "armed again after LAND")
            action.disarm()
        finally:
            sdk.destroy()
