"""Regression tests of issue 14 on the sim backend: a COMMAND_LONG whose used parameters are
NaN or inf (with a valid CRC) is refused at the edge, counted by message and field, and the
sim keeps serving telemetry and commands."""

from __future__ import annotations

import math

import pytest

from ridsafe.common import messages as m
from ridsafe.common import topics
from ridsafe.common.logsink import MemorySink
from ridsafe.sim_backend.config import SimConfig
from ridsafe.sim_backend.world import SimBackend
from tests.sim_backend.helpers import SimPair, scenario


def _set_mode(param1: float, param2: float) -> m.CommandLong:
    params = (param1, param2, 0.0, 0.0, 0.0, 0.0, 0.0)
    return m.CommandLong(1, 1, int(m.MavCmd.DO_SET_MODE), 0, params)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, 1e30])
@pytest.mark.parametrize("param", ["param1", "param2"])
def test_do_set_mode_with_a_non_finite_parameter_is_refused_and_the_sim_lives(
    bad: float, param: str
) -> None:
    pair = SimPair()
    pair.run(0.5)
    command = _set_mode(bad, 4.0) if param == "param1" else _set_mode(1.0, bad)
    for _ in range(10):
        pair.step([command])
    counters = pair.backend.counter_values()
    assert counters[f"invalid.COMMAND_LONG.{param}"] == 10
    assert counters["handler_errors"] == 0
    got = pair.step([_set_mode(1.0, float(m.CopterMode.GUIDED))])
    got += pair.run(0.2)
    acks = [r.message for r in got if isinstance(r.message, m.CommandAck)]
    assert [a.result for a in acks] == [int(m.MavResult.ACCEPTED)]
    assert any(isinstance(r.message, m.GlobalPositionInt) for r in got)


@pytest.mark.parametrize(
    ("command", "params", "field"),
    [
        (m.MavCmd.NAV_TAKEOFF, (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, math.nan), "param7"),
        (m.MavCmd.SET_MESSAGE_INTERVAL, (33.0, math.inf, 0.0, 0.0, 0.0, 0.0, 0.0), "param2"),
        (m.MavCmd.REQUEST_MESSAGE, (2.0**40, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0), "param1"),
        (m.MavCmd.NAV_LAND, (0.0, math.inf, 0.0, 0.0, 0.0, 0.0, 0.0), "param2"),
    ],
)
def test_used_parameters_must_be_finite_and_fit_their_integers(
    command: int, params: tuple[float, ...], field: str
) -> None:
    pair = SimPair()
    got = pair.step([m.CommandLong(1, 1, int(command), 0, params)])  # type: ignore[arg-type]
    assert not any(isinstance(r.message, m.CommandAck) for r in got)
    assert pair.backend.counter_values()[f"invalid.COMMAND_LONG.{field}"] == 1


def test_unused_command_parameters_may_be_nan_as_mavlink_allows() -> None:
    pair = SimPair()
    params = (1.0, float(m.CopterMode.GUIDED), math.nan, math.nan, math.nan, math.nan, math.nan)
    got = pair.step([m.CommandLong(1, 1, int(m.MavCmd.DO_SET_MODE), 0, params)])
    got += pair.run(0.1)
    acks = [r.message for r in got if isinstance(r.message, m.CommandAck)]
    assert [a.result for a in acks] == [int(m.MavResult.ACCEPTED)]


def test_setpoints_with_impossible_speeds_are_refused_by_field() -> None:
    pair = SimPair()
    setpoint = m.SetPositionTargetLocalNed(
        1.0, 1, 1, 1, 0, (0.0, 0.0, -10.0), (5000.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0, 0.0
    )
    pair.step([setpoint])
    assert pair.backend.counter_values()["invalid.SET_POSITION_TARGET_LOCAL_NED.v_ned_m_s"] == 1


def test_the_sim_logs_its_counters_at_the_end() -> None:
    sink = MemorySink()
    backend = SimBackend(scenario(), SimConfig(), sink=sink)
    pair = SimPair(backend)
    pair.step([_set_mode(math.nan, 4.0)])
    backend.finish(pair.t_s)
    ((_, record),) = sink.on(topics.APP_COUNTERS)
    assert record["app"] == "sim"
    assert record["counters"]["invalid.COMMAND_LONG.param1"] == 1
