"""The flight-phase machine: its tables, command retries and bounds, and the same behaviour
against the sim with an ACK lost in the router and a command the autopilot refuses."""

from __future__ import annotations

from dataclasses import replace

import pytest

from ridsafe.common import codec, topics
from ridsafe.common import messages as m
from ridsafe.common.dialect import ridsafe_v20 as mav
from ridsafe.common.messages import MavCmd, MavResult
from ridsafe.companion.config import CompanionConfig, OnArrival
from ridsafe.companion.mission import (
    PHASE_COMMANDS,
    PHASE_CONDITIONS,
    TRANSITIONS,
    FlightStatus,
    Mission,
    Phase,
    Trigger,
)
from ridsafe.sim_backend.autopilot import AutopilotConfig
from ridsafe.sim_backend.config import SimConfig
from tests.companion.test_companion_core import Flight, make_scenario

SYSID = 3
UP = FlightStatus(link_up=True, heartbeat_s=0.0)

# --- the tables -----------------------------------------------------------------------------


def test_every_phase_but_the_terminal_ones_has_a_way_out_and_every_phase_is_reachable() -> None:
    sources = {phase for phase, _ in TRANSITIONS}
    targets = set(TRANSITIONS.values()) | {Phase.WAIT_HEARTBEAT}
    assert targets == set(Phase)
    assert sources == set(Phase) - {Phase.DONE, Phase.FAILED}
    # a phase leaves either by a condition or by its commands
    for phase in sources:
        assert phase in PHASE_CONDITIONS or phase in PHASE_COMMANDS, phase


def test_every_required_command_phase_fails_the_mission_when_its_command_fails() -> None:
    config = CompanionConfig()
    for phase, build in PHASE_COMMANDS.items():
        specs = build(config)
        assert specs, phase
        if any(spec.required for spec in specs):
            assert TRANSITIONS[(phase, Trigger.COMMANDS_FAILED)] is Phase.FAILED
        else:
            assert (phase, Trigger.COMMANDS_FAILED) not in TRANSITIONS


def test_stream_requests_ask_for_the_configured_rates() -> None:
    specs = PHASE_COMMANDS[Phase.REQUEST_STREAMS](CompanionConfig())
    requested = {int(s.params[0]): s.params[1] for s in specs}
    # GLOBAL_POSITION_INT 10 Hz, LOCAL_POSITION_NED 10 Hz, SYSTEM_TIME 1 Hz, HOME 0.5 Hz
    assert requested == {
        33: 200_000.0,
        32: 200_000.0,
        2: 1_000_000.0,
        242: 2_000_000.0,
        30: -1.0,  # ATTITUDE and SYS_STATUS: not read, so turned off
        1: -1.0,
    }
    assert all(s.command is MavCmd.SET_MESSAGE_INTERVAL and not s.required for s in specs)


def test_stream_message_ids_are_the_dialects() -> None:
    ids = {int(s.params[0]) for s in PHASE_COMMANDS[Phase.REQUEST_STREAMS](CompanionConfig())}
    assert ids == {
        mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,
        mav.MAVLINK_MSG_ID_LOCAL_POSITION_NED,
        mav.MAVLINK_MSG_ID_SYSTEM_TIME,
        mav.MAVLINK_MSG_ID_HOME_POSITION,
        mav.MAVLINK_MSG_ID_ATTITUDE,
        mav.MAVLINK_MSG_ID_SYS_STATUS,
    }


# --- commands against a scripted autopilot ---------------------------------------------------


def _ack(command: int, result: MavResult) -> m.CommandAck:
    return m.CommandAck(command, int(result), SYSID, 191)


def _mission_at(phase: Phase, config: CompanionConfig | None = None) -> Mission:
    mission = Mission(config or CompanionConfig(), SYSID)
    mission.phase = phase
    mission.commands.load(PHASE_COMMANDS[phase](mission.config))
    return mission


def test_a_command_without_ack_is_resent_with_confirmation_counting_up() -> None:
    mission = _mission_at(Phase.ARM)
    sent = [mission.step(0.0, UP), mission.step(0.5, UP), mission.step(1.0, UP)]
    assert [len(s) for s in sent] == [1, 0, 1]
    first, second = sent[0][0], sent[2][0]
    assert (first.command, first.confirmation) == (MavCmd.COMPONENT_ARM_DISARM, 0)
    assert second.confirmation == 1
    assert (first.target_system, first.target_component) == (SYSID, 1)
    assert first.params[0] == 1.0
    events = [e.event for e in mission.take_events()]
    assert events == ["command_timeout", "command_retry"]
    mission.on_ack(1.1, _ack(MavCmd.COMPONENT_ARM_DISARM, MavResult.ACCEPTED))
    mission.step(1.2, UP)
    assert mission.phase is Phase.TAKEOFF


def test_a_rejection_is_logged_with_its_result_and_retried_after_the_timeout() -> None:
    mission = _mission_at(Phase.ARM)
    mission.step(0.0, UP)
    mission.on_ack(0.1, _ack(MavCmd.COMPONENT_ARM_DISARM, MavResult.TEMPORARILY_REJECTED))
    (event,) = mission.take_events()
    assert event.event == "command_rejected"
    assert event.fields["result"] == 1
    assert event.fields["result_name"] == "TEMPORARILY_REJECTED"
    assert "TEMPORARILY_REJECTED (1)" in event.detail
    assert mission.step(0.5, UP) == []
    assert len(mission.step(1.1, UP)) == 1


def test_retries_are_bounded_then_the_mission_fails() -> None:
    config = replace(CompanionConfig(), command_retries=2)
    mission = _mission_at(Phase.TAKEOFF, config)
    sends = 0
    for k in range(40):
        t = 0.25 * k
        out = mission.step(t, UP)
        sends += len(out)
        for cmd in out:
            mission.on_ack(t, _ack(cmd.command, MavResult.FAILED))
    assert sends == 3
    assert mission.phase is Phase.FAILED
    events = mission.take_events()
    assert [e.event for e in events].count("command_rejected") == 3
    assert any(e.event == "command_failed" for e in events)


def test_an_optional_command_that_is_refused_is_skipped() -> None:
    mission = _mission_at(Phase.REQUEST_STREAMS)
    t = 0.0
    while mission.phase is Phase.REQUEST_STREAMS and t < 1.0:
        for cmd in mission.step(t, UP):
            refused = int(cmd.params[0]) == 242  # no HOME_POSITION stream on this autopilot
            result = MavResult.UNSUPPORTED if refused else MavResult.ACCEPTED
            mission.on_ack(t, _ack(cmd.command, result))
        t += 0.02
    assert mission.phase is Phase.SET_GUIDED
    rejected = [e for e in mission.take_events() if e.event == "command_rejected"]
    assert [e.fields["label"] for e in rejected] == ["stream home_position"]


def test_nothing_is_sent_and_no_attempt_used_while_the_link_is_down() -> None:
    config = replace(CompanionConfig(), command_retries=1)
    mission = _mission_at(Phase.ARM, config)
    down = FlightStatus(link_up=False, heartbeat_s=0.0)
    assert len(mission.step(0.0, UP)) == 1
    for k in range(1, 50):
        assert mission.step(0.5 * k, down) == []
    assert mission.phase is Phase.ARM
    assert len(mission.step(30.0, UP)) == 1  # the one retry is still there


def test_an_ack_for_another_command_or_from_nowhere_changes_nothing() -> None:
    mission = _mission_at(Phase.ARM)
    mission.step(0.0, UP)
    assert not mission.on_ack(0.1, _ack(MavCmd.NAV_TAKEOFF, MavResult.ACCEPTED))
    mission.step(0.2, UP)
    assert mission.phase is Phase.ARM


def test_in_progress_extends_the_wait() -> None:
    mission = _mission_at(Phase.TAKEOFF)
    mission.step(0.0, UP)
    mission.on_ack(0.9, _ack(MavCmd.NAV_TAKEOFF, MavResult.IN_PROGRESS))
    assert mission.step(1.5, UP) == []  # no timeout: the autopilot is working on it
    mission.on_ack(1.6, _ack(MavCmd.NAV_TAKEOFF, MavResult.ACCEPTED))
    mission.step(1.7, UP)
    assert mission.phase is Phase.CLIMB


@pytest.mark.parametrize(
    ("phase", "status", "expected"),
    [
        (Phase.CLIMB, FlightStatus(True, 1.0, True, 9.2), Phase.CRUISE),
        (Phase.CLIMB, FlightStatus(True, 1.0, True, 8.8), Phase.CLIMB),
        (Phase.CLIMB, FlightStatus(True, 1.0, False, 3.0), Phase.FAILED),
        (Phase.CLIMB, FlightStatus(True, 0.0, False, 3.0), Phase.CLIMB),  # heartbeat predates
        (Phase.CRUISE, FlightStatus(True, 1.0, True, 30, 9.0, 4.0, 6.0), Phase.HOVER),
        (Phase.CRUISE, FlightStatus(True, 1.0, True, 30, 11.0, 1.0, 6.0), Phase.CRUISE),
        (Phase.CRUISE, FlightStatus(True, 1.0, True, 30, 2.0, 40.0, 6.0), Phase.HOVER),  # 40 m off
        (Phase.HOVER, FlightStatus(True, 1.0, True, 30, 2.0, 1.0, 0.3), Phase.DONE),
        (Phase.TAKEOFF, FlightStatus(True, 1.0, True, 40.0), Phase.CRUISE),  # restarted aloft
    ],
)
def test_conditions_move_the_phase(phase: Phase, status: FlightStatus, expected: Phase) -> None:
    mission = Mission(replace(CompanionConfig(), on_arrival=OnArrival.HOVER), SYSID)
    mission.phase, mission.entered_s = phase, 0.5
    mission.step(2.0, status)
    assert mission.phase is expected


@pytest.mark.parametrize(
    ("alt_error_m", "expected"), [(4.0, Phase.HOVER), (6.0, Phase.CRUISE), (None, Phase.CRUISE)]
)
def test_an_altitude_tolerance_asks_for_the_cruise_level_too(
    alt_error_m: float | None, expected: Phase
) -> None:
    config = replace(CompanionConfig(), arrival_alt_tolerance_m=5.0, on_arrival=OnArrival.HOVER)
    mission = Mission(config, SYSID)
    mission.phase, mission.entered_s = Phase.CRUISE, 0.5
    mission.step(2.0, FlightStatus(True, 1.0, True, 30, 2.0, alt_error_m, 6.0))
    assert mission.phase is expected


def test_arrival_lands_when_configured_and_land_ends_on_disarm() -> None:
    mission = Mission(replace(CompanionConfig(), on_arrival=OnArrival.LAND), SYSID)
    mission.phase = Phase.CRUISE
    phases, sent = [], []
    for altitude_m in (30.0, 12.5, 11.5):  # arrive, descend under the planner, hand over
        sent.append(mission.step(1.0, FlightStatus(True, 1.0, True, altitude_m, 2.0, 1.0, 1.0)))
        phases.append(mission.phase)
    assert phases == [Phase.DESCEND, Phase.DESCEND, Phase.LAND]
    assert sent[:2] == [[], []]  # the planner flies the descent
    assert [c.command for c in sent[2]] == [MavCmd.NAV_LAND]
    mission.on_ack(1.1, _ack(MavCmd.NAV_LAND, MavResult.ACCEPTED))
    mission.step(1.2, FlightStatus(True, 1.1, True, 20.0))
    assert mission.phase is Phase.LAND
    mission.step(30.0, FlightStatus(True, 29.0, False, 0.0))
    assert _phase(mission) is Phase.DONE


def test_the_landing_is_handed_over_only_over_the_site() -> None:
    """Pushed off its site in the descent, the aircraft is low enough but 20 m away: LAND
    would come straight down beside the site, so the planner brings it back first."""
    mission = Mission(replace(CompanionConfig(), on_arrival=OnArrival.LAND), SYSID)
    mission.phase = Phase.DESCEND
    assert mission.step(1.0, FlightStatus(True, 1.0, True, 11.0, 20.0, 11.0, 1.0)) == []
    assert mission.phase is Phase.DESCEND
    assert mission.step(2.0, FlightStatus(True, 2.0, True, 11.0, None, None, 1.0)) == []
    assert mission.phase is Phase.DESCEND  # no position yet: not over the site either
    sent = mission.step(3.0, FlightStatus(True, 3.0, True, 11.0, 4.0, 11.0, 1.0))
    assert _phase(mission) is Phase.LAND
    assert [c.command for c in sent] == [MavCmd.NAV_LAND]


def _phase(mission: Mission) -> Phase:
    """The phase now (a call, so the type checker does not carry an earlier narrowing)."""
    return mission.phase


# --- against the sim ----------------------------------------------------------------------------


class AckDropper:
    """Router hook: drops the first COMMAND_ACK for ``command`` (re-packing what else came)."""

    def __init__(self, command: int) -> None:
        self.command = command
        self.dropped = 0
        self.tap = codec.MavlinkLink(0, 0)
        self.links: dict[tuple[int, int], codec.MavlinkLink] = {}

    def __call__(self, sysid: int, data: bytes) -> bytes | None:
        out = bytearray()
        for received in self.tap.feed(data):
            msg = received.message
            if isinstance(msg, m.CommandAck) and msg.command == self.command and not self.dropped:
                self.dropped += 1
                continue
            key = (received.src_system, received.src_component)
            link = self.links.setdefault(key, codec.MavlinkLink(*key))
            out += link.pack(msg)
        return bytes(out) if out else None


class CommandCounter:
    """Router hook on the way up: counts COMMAND_LONGs by command id."""

    def __init__(self) -> None:
        self.tap = codec.MavlinkLink(0, 0)
        self.commands: list[m.CommandLong] = []

    def __call__(self, sysid: int, data: bytes) -> bytes:
        for received in self.tap.feed(data):
            if isinstance(received.message, m.CommandLong):
                self.commands.append(received.message)
        return data


def test_a_lost_ack_makes_the_companion_resend_and_the_flight_goes_on() -> None:
    flight = Flight(make_scenario(1))
    flight.down = dropper = AckDropper(MavCmd.COMPONENT_ARM_DISARM)
    flight.up = counter = CommandCounter()
    flight.run_until(lambda: flight.companions[1].phase is Phase.CRUISE, max_s=20.0)
    assert dropper.dropped == 1
    arms = [c for c in counter.commands if c.command == MavCmd.COMPONENT_ARM_DISARM]
    assert [c.confirmation for c in arms] == [0, 1]
    assert flight.events(1, "command_timeout")[0]["label"] == "arm"
    assert flight.events(1, "command_retry")[0]["attempt"] == 2


def test_a_refused_arm_is_logged_with_the_result_and_retried_until_accepted() -> None:
    # ArduPilot with Remote ID enforcement refuses to arm until the transponder is ready;
    # holding the companion's Remote ID back for 3 s makes the first ARM attempts fail.
    sim_config = SimConfig(autopilot=AutopilotConfig(require_remote_id_to_arm=True))
    flight = Flight(make_scenario(1), sim_config=sim_config)
    tap = codec.MavlinkLink(0, 0)
    relink = codec.MavlinkLink(1, 191)

    def hold_rid(sysid: int, data: bytes) -> bytes | None:
        if flight.t_s >= 3.0:
            return data
        kept = [
            r.message for r in tap.feed(data) if not type(r.message).__name__.startswith("Odid")
        ]
        return relink.pack_all(kept) or None

    flight.up = hold_rid
    flight.run_until(lambda: flight.companions[1].phase is Phase.CLIMB, max_s=20.0)
    rejected = flight.events(1, "command_rejected")
    assert rejected and all(e["label"] == "arm" for e in rejected)
    assert {e["result_name"] for e in rejected} == {"FAILED"}
    assert all(e["result"] == MavResult.FAILED for e in rejected)
    texts = [e["detail"] for e in flight.events(1, "autopilot_text")]
    assert "PreArm: Remote ID not ready" in texts
    accepted = [e for e in flight.events(1, "command_accepted") if e["label"] == "arm"]
    assert accepted and accepted[0]["attempt"] == len(rejected) + 1
    records = flight.sinks[1].on(topics.COMPANION_EVENTS)
    assert all(set(topics.TOPICS[topics.COMPANION_EVENTS][1]) <= set(r) for _, r in records)


def test_waits_on_the_ground_until_its_departure_time() -> None:
    mission = Mission(CompanionConfig(), SYSID)
    mission.phase = Phase.WAIT_DEPARTURE
    phases = []
    for t, due in ((10.0, False), (10.5, True)):
        mission.step(t, FlightStatus(link_up=True, heartbeat_s=t - 0.1, departure_due=due))
        phases.append(mission.phase)
    assert phases == [Phase.WAIT_DEPARTURE, Phase.SET_GUIDED]


# --- a mode that does not stay ----------------------------------------------------------------

STABILIZE = 0


def _phase_now(mission: Mission) -> Phase:
    return mission.phase  # read afresh: a step() changes it behind mypy's narrowing


def test_a_mode_dropped_while_arming_or_taking_off_is_set_again() -> None:
    """A real ArduCopter that finishes starting up after GUIDED was accepted goes back to
    STABILIZE, where it arms but refuses the take-off: the mission sets GUIDED again."""
    for phase in (Phase.ARM, Phase.TAKEOFF):
        mission = _mission_at(phase)
        mission.entered_s = 0.5
        sent = mission.step(2.0, replace(UP, heartbeat_s=1.0, custom_mode=STABILIZE))
        assert mission.phase is Phase.SET_GUIDED, phase
        assert [(c.command, c.params[1]) for c in sent] == [(MavCmd.DO_SET_MODE, 4.0)]
        mission.on_ack(2.1, _ack(MavCmd.DO_SET_MODE, MavResult.ACCEPTED))
        mission.step(2.2, replace(UP, heartbeat_s=1.0, custom_mode=STABILIZE))
        assert _phase_now(mission) is Phase.ARM  # the stale heartbeat predates the new phase


def test_guided_or_an_old_heartbeat_changes_nothing() -> None:
    for status in (
        replace(UP, heartbeat_s=1.0, custom_mode=4),  # GUIDED
        replace(UP, heartbeat_s=0.2, custom_mode=STABILIZE),  # heard before the phase began
        replace(UP, heartbeat_s=1.0),  # mode not known
    ):
        mission = _mission_at(Phase.TAKEOFF)
        mission.entered_s = 0.5
        mission.step(2.0, status)
        assert mission.phase is Phase.TAKEOFF, status


def test_setting_guided_again_is_bounded_then_the_refused_take_off_fails_the_mission() -> None:
    config = replace(CompanionConfig(), command_retries=1)
    mission = _mission_at(Phase.TAKEOFF, config)
    t = 0.0
    for _ in range(60):
        t += 0.25
        for cmd in mission.step(t, replace(UP, heartbeat_s=t - 0.1, custom_mode=STABILIZE)):
            result = MavResult.FAILED if cmd.command == MavCmd.NAV_TAKEOFF else MavResult.ACCEPTED
            mission.on_ack(t, _ack(cmd.command, result))
    assert mission.mode_reasserts == config.command_attempts
    assert mission.phase is Phase.FAILED
