"""The companion-loss failsafe: a setpoint stream that stops in GUIDED -> LAND / RTL / hold.

A real companion (the ``Companion`` core) flies against the real sim in memory; the link from
it to the autopilot is cut in CRUISE, as when the companion computer dies.
"""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from ridsafe.common import topics
from ridsafe.common.logsink import MemorySink
from ridsafe.common.messages import CopterMode
from ridsafe.companion.mission import Phase
from ridsafe.sim_backend.autopilot import AutopilotConfig, FailsafeAction
from ridsafe.sim_backend.config import SimConfig
from tests.companion.test_companion_core import Flight, make_scenario


def _cut_in_cruise(action: FailsafeAction | None = None) -> Flight:
    autopilot = (
        AutopilotConfig() if action is None else AutopilotConfig(companion_loss_action=action)
    )
    flight = Flight(make_scenario(1), sim_config=SimConfig(autopilot=autopilot))
    flight.sim.sink = MemorySink()
    companion = flight.companions[1]
    flight.run_until(lambda: companion.phase is Phase.CRUISE, max_s=40.0)
    flight.run(2.0)  # a few setpoints: the stream is established
    flight.up = lambda sysid, data: None  # the companion computer is gone
    return flight


def test_a_companion_that_stops_sending_makes_the_aircraft_land_and_disarm() -> None:
    flight = _cut_in_cruise()
    autopilot = flight.sim.autopilots[0]
    cut_s = flight.t_s
    flight.run(9.0)
    assert autopilot.mode is CopterMode.GUIDED and autopilot.failsafes == 0
    flight.run_until(lambda: autopilot.mode is CopterMode.LAND, max_s=5.0)
    assert 9.0 < flight.t_s - cut_s < 11.5  # 10 s after the last setpoint before the cut
    flight.run_until(lambda: not autopilot.armed, max_s=80.0)
    assert flight.sim.truth().p_enu_m[0][2] < 0.2
    sink = flight.sim.sink
    assert isinstance(sink, MemorySink)
    events = [r for _, r in sink.on(topics.SIM_EVENTS)]
    assert len(events) == 1
    assert events[0]["event"] == "companion_loss" and events[0]["action"] == "land"
    assert set(topics.TOPICS[topics.SIM_EVENTS][1]) <= set(events[0])
    assert autopilot.failsafes == 1


def test_rtl_action_flies_home_before_landing() -> None:
    flight = _cut_in_cruise(FailsafeAction.RTL)
    autopilot = flight.sim.autopilots[0]
    flight.run_until(lambda: autopilot.mode is CopterMode.RTL, max_s=15.0)
    flight.run_until(lambda: not autopilot.armed, max_s=150.0)
    home = flight.sim.homes[0].home_enu_m
    assert math.dist(flight.sim.truth().p_enu_m[0][:2], home[:2]) < 3.0


def test_hold_action_stays_in_guided_and_holds_position() -> None:
    flight = _cut_in_cruise(FailsafeAction.HOLD)
    autopilot = flight.sim.autopilots[0]
    flight.run_until(lambda: autopilot.failsafes == 1, max_s=15.0)
    flight.run(5.0)
    before = flight.sim.truth().p_enu_m[0].copy()
    flight.run(5.0)
    assert autopilot.mode is CopterMode.GUIDED and autopilot.armed
    assert math.dist(before, flight.sim.truth().p_enu_m[0]) < 0.5


@pytest.mark.parametrize("timeout_s", [0.0])
def test_a_zero_timeout_disables_the_failsafe(timeout_s: float) -> None:
    config = SimConfig(autopilot=replace(AutopilotConfig(), companion_loss_timeout_s=timeout_s))
    flight = Flight(make_scenario(1), sim_config=config)
    companion = flight.companions[1]
    flight.run_until(lambda: companion.phase is Phase.CRUISE, max_s=40.0)
    flight.run(2.0)
    flight.up = lambda sysid, data: None
    flight.run(15.0)
    autopilot = flight.sim.autopilots[0]
    assert autopilot.mode is CopterMode.GUIDED and autopilot.failsafes == 0


def test_a_full_flight_never_triggers_it() -> None:
    flight = Flight(make_scenario(1))
    companion = flight.companions[1]
    flight.run_until(lambda: companion.phase is Phase.DONE, max_s=60.0)
    assert flight.sim.autopilots[0].failsafes == 0
