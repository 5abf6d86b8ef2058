"""The autopilot's command table, modes, GUIDED targets and failsafes, over real MAVLink bytes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ridsafe.common import codec
from ridsafe.common import messages as m
from ridsafe.common.messages import CopterMode, MavCmd, MavResult
from ridsafe.common.messages import PositionTargetMask as Mask
from ridsafe.sim_backend.autopilot import COMMAND_HANDLERS, FORCE_DISARM_MAGIC
from ridsafe.sim_backend.world import EndpointKind
from tests.sim_backend.helpers import SimPair

ACCEPTED, DENIED, FAILED, UNSUPPORTED = (
    MavResult.ACCEPTED,
    MavResult.DENIED,
    MavResult.FAILED,
    MavResult.UNSUPPORTED,
)


def _target(
    p_ned: tuple[float, float, float], mask: int = Mask.POSITION_ONLY, **kw: object
) -> m.SetPositionTargetLocalNed:
    fields: dict[str, object] = {
        "time_boot_s": 0.0,
        "target_system": 1,
        "target_component": 1,
        "coordinate_frame": m.MavFrame.LOCAL_NED,
        "type_mask": int(mask),
        "p_ned_m": p_ned,
        "v_ned_m_s": (0.0, 0.0, 0.0),
        "a_ned_m_s2": (0.0, 0.0, 0.0),
        "yaw_rad": 0.0,
        "yaw_rate_rad_s": 0.0,
    }
    fields.update(kw)
    return m.SetPositionTargetLocalNed(**fields)  # type: ignore[arg-type]


@pytest.fixture
def pair() -> SimPair:
    p = SimPair()
    p.run(1.0)
    return p


@pytest.fixture
def flying() -> SimPair:
    p = SimPair()
    p.run(0.5)
    p.take_off(20.0)
    return p


# --- heartbeat ------------------------------------------------------------------------------


def test_heartbeat_looks_like_arducopter_sitl(pair: SimPair) -> None:
    hb = pair.latest(m.Heartbeat)
    assert isinstance(hb, m.Heartbeat)
    assert (hb.mav_type, hb.autopilot) == (m.MavType.OCTOROTOR, m.MavAutopilot.ARDUPILOTMEGA)
    assert hb.custom_mode == CopterMode.STABILIZE and hb.base_mode == 81 and not hb.armed
    assert pair.command(MavCmd.DO_SET_MODE, 1, CopterMode.GUIDED).result == ACCEPTED
    assert pair.command(MavCmd.COMPONENT_ARM_DISARM, 1).result == ACCEPTED
    pair.run(1.1)
    hb = pair.latest(m.Heartbeat)
    assert isinstance(hb, m.Heartbeat)
    assert hb.base_mode == 217 and hb.custom_mode == CopterMode.GUIDED and hb.armed
    assert hb.system_status == m.MavState.ACTIVE


def test_every_command_long_gets_exactly_one_ack(pair: SimPair) -> None:
    for command in [*COMMAND_HANDLERS, 183, 0, 65535]:
        ack = pair.command(command, 0)
        assert ack.command == command
        assert ack.target_system == 255 and ack.target_component == 190


# --- the command table: accepted and rejected ------------------------------------------------


def test_arm_accepted_in_guided_and_rejected_in_unarmable_mode(pair: SimPair) -> None:
    assert pair.command(MavCmd.DO_SET_MODE, 1, CopterMode.LAND).result == ACCEPTED
    assert pair.command(MavCmd.COMPONENT_ARM_DISARM, 1).result == FAILED
    assert "Arm: Mode not armable" in pair.texts()
    assert pair.command(MavCmd.DO_SET_MODE, 1, CopterMode.GUIDED).result == ACCEPTED
    assert pair.command(MavCmd.COMPONENT_ARM_DISARM, 1).result == ACCEPTED
    assert pair.command(MavCmd.COMPONENT_ARM_DISARM, 1).result == ACCEPTED  # already armed
    assert bool(pair.backend.fleet.armed[0])


def test_arm_param_neither_zero_nor_one_is_denied(pair: SimPair) -> None:
    assert pair.command(MavCmd.COMPONENT_ARM_DISARM, 2).result == DENIED
    assert not bool(pair.backend.fleet.armed[0])


def test_disarm_on_ground_accepted(pair: SimPair) -> None:
    pair.command(MavCmd.DO_SET_MODE, 1, CopterMode.GUIDED)
    pair.command(MavCmd.COMPONENT_ARM_DISARM, 1)
    assert pair.command(MavCmd.COMPONENT_ARM_DISARM, 0).result == ACCEPTED
    assert not bool(pair.backend.fleet.armed[0])


def test_disarm_in_flight_needs_force_then_vehicle_falls(flying: SimPair) -> None:
    assert flying.command(MavCmd.COMPONENT_ARM_DISARM, 0).result == FAILED
    assert bool(flying.backend.fleet.armed[0])
    alt_before = flying.altitude_m()
    result = flying.command(MavCmd.COMPONENT_ARM_DISARM, 0, FORCE_DISARM_MAGIC).result
    assert result == ACCEPTED
    flying.run(1.0)
    assert flying.altitude_m() < alt_before - 3.0  # motors stopped: free fall


@pytest.mark.parametrize(
    ("setup", "alt_m", "expected"),
    [
        ("disarmed", 20.0, FAILED),
        ("armed_loiter", 20.0, FAILED),
        ("armed_guided", 1e30, DENIED),  # NaN: refused at the edge (test_sim_hardening)
        ("armed_guided", 600.0, DENIED),
        ("armed_guided", -5.0, DENIED),
        ("armed_guided", 20.0, ACCEPTED),
    ],
)
def test_takeoff_table(pair: SimPair, setup: str, alt_m: float, expected: MavResult) -> None:
    if setup == "armed_loiter":
        pair.command(MavCmd.DO_SET_MODE, 1, CopterMode.LOITER)
        assert pair.command(MavCmd.COMPONENT_ARM_DISARM, 1).result == ACCEPTED
    elif setup == "armed_guided":
        pair.command(MavCmd.DO_SET_MODE, 1, CopterMode.GUIDED)
        assert pair.command(MavCmd.COMPONENT_ARM_DISARM, 1).result == ACCEPTED
    assert pair.command(MavCmd.NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, alt_m).result == expected
    if expected == ACCEPTED:
        pair.run(15.0)
        assert pair.altitude_m() == pytest.approx(alt_m, abs=0.5)
    else:
        pair.run(2.0)
        assert pair.altitude_m() < 0.1


def test_takeoff_while_flying_is_rejected(flying: SimPair) -> None:
    assert flying.command(MavCmd.NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 40.0).result == FAILED


@pytest.mark.parametrize(
    ("base_mode", "custom_mode", "expected"),
    [
        (1, CopterMode.GUIDED, ACCEPTED),
        (1, CopterMode.LOITER, ACCEPTED),
        (1, 99, FAILED),  # no such ArduCopter mode
        (1, CopterMode.AUTO, FAILED),  # AUTO needs a mission; benign vehicles have none
        (0, CopterMode.GUIDED, DENIED),  # only custom modes
        # a NaN mode never reaches the autopilot: tests/sim_backend/test_sim_hardening.py
    ],
)
def test_set_mode_table(
    pair: SimPair, base_mode: float, custom_mode: float, expected: MavResult
) -> None:
    assert pair.command(MavCmd.DO_SET_MODE, base_mode, custom_mode).result == expected
    hb_mode = pair.backend.autopilots[0].mode
    assert (hb_mode == custom_mode) == (expected == ACCEPTED)


def test_legacy_set_mode_message_is_acked_as_command_11(pair: SimPair) -> None:
    got = [r.message for r in pair.step([m.SetMode(1, 1, CopterMode.GUIDED)])]
    acks = [a for a in got if isinstance(a, m.CommandAck)]
    assert len(acks) == 1 and acks[0].command == 11 and acks[0].result == ACCEPTED
    assert pair.backend.autopilots[0].mode is CopterMode.GUIDED


def test_land_descends_and_disarms(flying: SimPair) -> None:
    assert flying.command(MavCmd.NAV_LAND).result == ACCEPTED
    flying.run(30.0)
    assert flying.altitude_m() < 0.05
    assert not bool(flying.backend.fleet.armed[0])
    assert any(t.startswith("Disarming motors") for t in flying.texts())


def test_rtl_returns_home_lands_and_disarms(flying: SimPair) -> None:
    flying.step([_target((60.0, 40.0, -20.0))])
    flying.run(20.0)
    assert flying.command(MavCmd.NAV_RETURN_TO_LAUNCH).result == ACCEPTED
    flying.run(60.0)
    home = flying.backend.homes[0].home_enu_m
    p = flying.position_enu()
    assert math.hypot(p[0] - home[0], p[1] - home[1]) < 2.5
    assert not bool(flying.backend.fleet.armed[0])


def test_set_message_interval_changes_the_rate(pair: SimPair) -> None:
    gpi = 33
    assert pair.command(MavCmd.SET_MESSAGE_INTERVAL, gpi, 500_000).result == ACCEPTED  # 2 Hz
    got = pair.run(5.0)
    count = sum(isinstance(r.message, m.GlobalPositionInt) for r in got)
    assert 9 <= count <= 11
    assert pair.command(MavCmd.SET_MESSAGE_INTERVAL, gpi, -1).result == ACCEPTED
    got = pair.run(2.0)
    assert not any(isinstance(r.message, m.GlobalPositionInt) for r in got)
    assert pair.command(MavCmd.SET_MESSAGE_INTERVAL, 9999, 100_000).result == FAILED


def test_request_message_sends_it_once(pair: SimPair) -> None:
    assert pair.command(MavCmd.SET_MESSAGE_INTERVAL, 242, -1).result == ACCEPTED
    pair.run(0.1)
    ack_step = pair.step([m.CommandLong(1, 1, MavCmd.REQUEST_MESSAGE, 0, (242, 0, 0, 0, 0, 0, 0))])
    later = pair.run(3.0)
    homes = [r for r in ack_step + later if isinstance(r.message, m.HomePosition)]
    assert len(homes) == 1
    assert pair.command(MavCmd.REQUEST_MESSAGE, 9999).result == FAILED


def test_unknown_command_is_unsupported(pair: SimPair) -> None:
    assert pair.command(183, 1, 1500).result == UNSUPPORTED


def test_commands_to_the_transponder_component_are_unsupported(pair: SimPair) -> None:
    companion = SimPair(pair.backend, kind=EndpointKind.COMPANION)
    companion.station = codec.MavlinkLink(1, 191)  # the companion port takes its own system
    companion.t_s = pair.t_s
    ack = companion.command(MavCmd.COMPONENT_ARM_DISARM, 1, target_component=236)
    assert ack.result == UNSUPPORTED
    assert not bool(pair.backend.fleet.armed[0])


# --- GUIDED targets -----------------------------------------------------------------------


def test_position_target_is_reached(flying: SimPair) -> None:
    flying.step([_target((40.0, -30.0, -25.0))])
    flying.run(25.0)
    pos = flying.latest(m.LocalPositionNed)
    assert isinstance(pos, m.LocalPositionNed)
    assert math.dist(pos.p_ned_m, (40.0, -30.0, -25.0)) < 0.5


def test_velocity_target_is_tracked_and_lapses_into_hold_after_3_s(flying: SimPair) -> None:
    velocity = (4.0, 3.0, 0.0)
    target = _target((0, 0, 0), Mask.VELOCITY_ONLY, v_ned_m_s=velocity)
    for _ in range(5):  # re-sent every second: keeps flying
        flying.step([target])
        flying.run(1.0)
    v = flying.latest(m.LocalPositionNed)
    assert isinstance(v, m.LocalPositionNed)
    assert math.dist(v.v_ned_m_s, velocity) < 0.3
    flying.run(3.5)  # no target for > 3 s: failsafe
    assert any("holding position" in t for t in flying.texts())
    flying.run(2.0)  # still inside the 10 s companion-loss timeout (tested in test_failsafe)
    before = flying.position_enu()
    flying.run(3.0)
    assert math.dist(before, flying.position_enu()) < 0.5


def test_offset_frame_target_is_relative_to_current_position(flying: SimPair) -> None:
    start = flying.backend.homes[0].enu_to_local_ned(flying.position_enu())
    flying.step([_target((10.0, 0.0, 0.0), coordinate_frame=m.MavFrame.LOCAL_OFFSET_NED)])
    flying.run(12.0)
    now = flying.backend.homes[0].enu_to_local_ned(flying.position_enu())
    assert np.allclose(now - start, (10.0, 0.0, 0.0), atol=0.5)


@pytest.mark.parametrize(
    ("message_kw", "why"),
    [
        ({"p_ned_m": (math.nan, 0.0, -20.0)}, "NaN"),
        ({"p_ned_m": (1e5, 0.0, -20.0)}, "out of range"),  # 1e9: refused at the edge
        ({"type_mask": int(Mask.VELOCITY_ONLY), "v_ned_m_s": (200.0, 0.0, 0.0)}, "out of range"),
        ({"type_mask": 0b110111111100}, "mixes"),  # x used, y and z ignored
        ({"type_mask": 0b110000111000}, "acceleration"),
        ({"type_mask": 0b110111111111}, "neither"),
        ({"coordinate_frame": m.MavFrame.GLOBAL}, "frame"),
    ],
)
def test_bad_targets_are_rejected_counted_and_explained(
    flying: SimPair, message_kw: dict[str, object], why: str
) -> None:
    before = flying.position_enu()
    flying.step([_target((50.0, 50.0, -20.0), Mask.POSITION_ONLY, **message_kw)])
    flying.run(2.0)
    assert flying.backend.autopilots[0].rejected_targets == 1
    assert any(why in t for t in flying.texts()), flying.texts()
    assert math.dist(before, flying.position_enu()) < 0.3


def test_nan_in_ignored_fields_is_fine(flying: SimPair) -> None:
    nan3 = (math.nan, math.nan, math.nan)
    flying.step([_target((20.0, 0.0, -20.0), v_ned_m_s=nan3, a_ned_m_s2=nan3, yaw_rad=math.nan)])
    assert flying.backend.autopilots[0].rejected_targets == 0


def test_targets_ignored_outside_guided_and_on_the_ground(pair: SimPair) -> None:
    pair.step([_target((50.0, 0.0, -20.0))])
    assert pair.backend.autopilots[0].rejected_targets == 1
    assert pair.command(MavCmd.DO_SET_MODE, 1, CopterMode.GUIDED).result == ACCEPTED
    pair.command(MavCmd.COMPONENT_ARM_DISARM, 1)
    pair.step([_target((50.0, 0.0, -20.0))])  # armed but not taken off
    assert pair.backend.autopilots[0].rejected_targets == 2
    pair.run(2.0)
    assert pair.altitude_m() < 0.1


def test_speed_is_limited_to_8_m_s_even_when_asked_for_more(flying: SimPair) -> None:
    target = _target((0, 0, 0), Mask.VELOCITY_ONLY, v_ned_m_s=(20.0, 0.0, 0.0))
    speeds = []
    for _ in range(8):
        flying.step([target])
        for _ in range(50):
            flying.step()
            speeds.append(float(np.linalg.norm(flying.backend.truth().v_enu_m_s[0])))
    assert max(speeds) <= 8.05 and max(speeds) > 7.5


def test_auto_disarm_after_10_s_armed_on_the_ground(pair: SimPair) -> None:
    pair.command(MavCmd.DO_SET_MODE, 1, CopterMode.GUIDED)
    pair.command(MavCmd.COMPONENT_ARM_DISARM, 1)
    pair.run(9.0)
    assert bool(pair.backend.fleet.armed[0])
    pair.run(2.0)
    assert not bool(pair.backend.fleet.armed[0])
