"""The companion against an autopilot that behaves like a real ArduCopter just after boot:
no position estimate (GUIDED and arming refused, "PreArm: Need Position Estimate") for a
while, and nothing streamed that was not asked for."""

from __future__ import annotations

from dataclasses import replace

from ridsafe.companion.config import CompanionConfig, OnArrival
from ridsafe.companion.mission import Phase
from ridsafe.sim_backend.autopilot import AutopilotConfig
from ridsafe.sim_backend.config import SimConfig
from ridsafe.sim_backend.telemetry import TelemetryRatesHz
from tests.companion.test_companion_core import Flight, make_scenario

LIKE_ARDUCOPTER = SimConfig(
    autopilot=AutopilotConfig(prearm_delay_s=20.0),
    telemetry_hz=TelemetryRatesHz(stream_unasked=False),
)
LANDING = replace(CompanionConfig(), on_arrival=OnArrival.LAND)


def test_companion_waits_out_the_prearm_period_then_flies_to_its_goal_and_lands() -> None:
    flight = Flight(make_scenario(1), LANDING, sim_config=LIKE_ARDUCOPTER)
    companion = flight.companions[1]
    flight.run(15.0)
    assert companion.phase is Phase.ARM  # GUIDED is accepted disarmed, as on ArduCopter
    assert flight.events(1, "waiting_prearm")
    texts = [str(e["detail"]) for e in flight.events(1, "autopilot_text")]
    assert "PreArm: Need Position Estimate" in texts  # every 30 s while disarmed
    assert "Arm: Need Position Estimate" in texts  # the answer to each refused arm
    flight.run_until(lambda: companion.phase is Phase.DONE, max_s=150.0)
    assert not flight.events(1, "command_failed")
    assert not flight.sim.truth().armed[0]


def test_companion_gives_up_after_the_configured_time_with_a_clear_message() -> None:
    config = replace(LANDING, prearm_give_up_s=5.0)
    flight = Flight(make_scenario(1), config, sim_config=LIKE_ARDUCOPTER)
    companion = flight.companions[1]
    flight.run_until(lambda: companion.phase is Phase.FAILED, max_s=15.0)
    failed = flight.events(1, "command_failed")
    assert len(failed) == 1 and "over 5 s (companion.prearm_give_up_s)" in str(failed[0]["detail"])
