"""The codec's edge checks on decoded inbound messages (``codec.inbound``)."""

from __future__ import annotations

import math

import pytest

from ridsafe.common import messages as m
from ridsafe.common import protocol_messages as p
from ridsafe.common.codec.inbound import first_invalid_field

NAN, INF = math.nan, math.inf
DO_REPOSITION = 192
GLOBAL_RELATIVE_ALT_INT = 6


def _command_int(command: int, params: tuple[float, ...]) -> p.CommandInt:
    return p.CommandInt(1, 1, GLOBAL_RELATIVE_ALT_INT, command, 0, 0, params)  # type: ignore[arg-type]


def test_an_impossible_unix_time_is_refused_by_field() -> None:
    assert first_invalid_field(m.SystemTime(float(2**64 - 1) / 1e6, 10.0)) == "time_unix_s"
    assert first_invalid_field(m.SystemTime(1.7e9, 10.0)) is None


@pytest.mark.parametrize("bad", [NAN, INF, -INF, 256.0])
def test_do_set_mode_needs_a_finite_uint8_base_mode(bad: float) -> None:
    cmd = m.CommandLong(1, 1, int(m.MavCmd.DO_SET_MODE), 0, (bad, 4.0, 0, 0, 0, 0, 0))
    assert first_invalid_field(cmd) == "param1"
    as_int = _command_int(int(m.MavCmd.DO_SET_MODE), (bad, 4.0, 0, 0, 0, 0, 0))
    assert first_invalid_field(as_int) == "param1"


def test_an_unused_nan_parameter_means_unset_in_command_int_as_in_command_long() -> None:
    """MAVSDK's goto_location: DO_REPOSITION with ground speed -1 and yaw NaN ("keep")."""
    goto = _command_int(DO_REPOSITION, (-1.0, 1.0, 0.0, NAN, 47.39, 8.54, 20.0))
    assert first_invalid_field(goto) is None
    long = m.CommandLong(1, 1, DO_REPOSITION, 0, (-1.0, 1.0, 0.0, NAN, 47.39, 8.54, 20.0))
    assert first_invalid_field(long) is None


def test_an_infinite_parameter_is_never_valid() -> None:
    assert first_invalid_field(_command_int(DO_REPOSITION, (INF, 0, 0, 0, 0, 0, 0))) == "param1"
