"""WPNAV_SPEED limits how fast the sim flies position-only targets, as ArduCopter's waypoint
navigation does: a ground station sets it over real UDP and flies a guided target; in memory,
the default (at or above the controller's cap) changes nothing."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from ridsafe.common.messages import CopterMode
from tests.sim_backend.helpers import SimPair
from tests.sim_backend.test_fence import Station, flying, go_to, set_params
from tests.sim_backend.udp_sim import sim_on_udp

GCS_BASE, COMPANION_BASE = 26350, 27560


def fly_north(station: Station, north_m: float, timeout_s: float) -> float:
    """Fly to ``north_m`` at 10 m; the fastest horizontal speed (m/s) seen on the way."""
    station.conn.mav.set_position_target_local_ned_send(
        0, station.conn.target_system, 1, 1, 0b110111111000, north_m, 0, -10, 0, 0, 0, 0, 0, 0,
        0, 0,
    )  # fmt: skip
    fastest = 0.0
    deadline = time.monotonic() + timeout_s
    while True:
        position = station.wait("LOCAL_POSITION_NED", 5.0)
        fastest = max(fastest, math.hypot(position.vx, position.vy))
        if abs(position.x - north_m) < 1.0:
            return fastest
        assert time.monotonic() < deadline, f"not there: {position}"


@pytest.mark.udp
def test_wpnav_speed_set_over_udp_limits_a_guided_position_target() -> None:
    with sim_on_udp(GCS_BASE, COMPANION_BASE, speed=4.0):
        station = Station(GCS_BASE)
        mav = station.conn.mav
        for msg_id in (32, 33):  # LOCAL_POSITION_NED, GLOBAL_POSITION_INT
            station.command(511, msg_id, 100_000)
        station.set_param("WPNAV_SPEED", 300)
        station.command(176, 1, int(CopterMode.GUIDED))
        station.command(400, 1)
        station.command(22, 0, 0, 0, 0, 0, 0, 10)
        deadline = time.monotonic() + 30
        while station.height_m() < 9.0:
            assert time.monotonic() < deadline, "no take-off"
        assert fly_north(station, 50.0, 60.0) < 3.3
        station.set_param("WPNAV_SPEED", 1000)  # back to the default: the controller's cap
        assert fly_north(station, 0.0, 60.0) > 6.0
        del mav


def test_the_default_wpnav_speed_flies_as_before() -> None:
    def track(**params: float) -> np.ndarray:
        pair = SimPair(dt_s=0.05)
        pair.run(0.5)
        set_params(pair, **params)
        flying(pair)
        go_to(pair, 60, 20, 10)
        points = []
        for _ in range(100):
            pair.run(0.2)
            points.append(pair.backend.truth().p_enu_m[0].copy())
        return np.array(points)

    assert np.array_equal(track(), track(WPNAV_SPEED=1000))
    slow = track(WPNAV_SPEED=200)
    steps = np.hypot(*np.diff(slow[:, :2], axis=0).T) / 0.2
    assert steps.max() < 2.2 and np.hypot(slow[-1, 0] - 20, slow[-1, 1] - 60) < 25
