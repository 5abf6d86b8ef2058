"""The codec's edge checks on decoded inbound messages (``codec.inbound``)."""

from __future__ import annotations

import dataclasses
import math
import typing

import numpy as np
import pytest

from ridsafe.common import messages as m
from ridsafe.common import protocol_messages as p
from ridsafe.common.codec.inbound import (
    _first_invalid_field_checked,
    _quick_check,
    first_invalid_field,
)

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


# -- the quick check against the field-by-field rules ----------------------------------------

_FLOATS = (0.0, 1.5, -3.0, 45.0, 1.0e5, -2.0e6, 5.0e9, NAN, INF, -INF, 1.0e308, -1.0e308)
_INTS = (0, 1, 7, 255, -5, 2**40)
_STRS = ("RSAF800000001", "", "bad\x00id", "caf\u00e9")
_WRONG = (5, 1.0, None, "x", np.float64(2.0), np.float64(NAN), (1.0, 2.0))


def _message_classes() -> list[type]:
    found = []
    for module in (m, p):
        for name in sorted(dir(module)):
            cls = getattr(module, name)
            if isinstance(cls, type) and dataclasses.is_dataclass(cls) and _quick_check(cls):
                found.append(cls)
    return found


_MAKERS: dict[type, typing.Callable[[np.random.Generator, bool], object]] = {
    float: lambda rng, broken: float(
        (_FLOATS if broken else _FLOATS[:5])[rng.integers(len(_FLOATS) if broken else 5)]
    ),
    int: lambda rng, broken: int(rng.choice(_INTS)),
    bool: lambda rng, broken: bool(rng.random() < 0.5),
    str: lambda rng, broken: _STRS[rng.integers(len(_STRS) if broken else 1)],
    bytes: lambda rng, broken: bytes(rng.integers(0, 256, int(rng.integers(0, 4))).tolist()),
}


def _value(rng: np.random.Generator, hint: object, broken: bool) -> object:
    """A value for a field annotated ``hint``: of that type, or (``broken``) anything."""
    if broken and rng.random() < 0.15:
        return _WRONG[rng.integers(len(_WRONG))]
    args = typing.get_args(hint)
    if typing.get_origin(hint) is tuple:
        return tuple(_value(rng, a, broken) for a in args)
    if type(None) in args and rng.random() < 0.2:
        return None
    base = next(t for t in _MAKERS if t is hint or t in args)
    return _MAKERS[base](rng, broken)


@pytest.mark.parametrize("cls", _message_classes(), ids=lambda cls: cls.__name__)
def test_the_quick_check_names_what_the_field_by_field_rules_name(cls: type) -> None:
    rng = np.random.default_rng(hash(cls.__name__) % 2**32)
    hints = typing.get_type_hints(cls)
    outcomes = set()
    for k in range(400):
        broken = k % 2 == 1
        values = [_value(rng, hints[f.name], broken) for f in dataclasses.fields(cls)]
        message = cls(*values)
        want = _outcome(_first_invalid_field_checked, message)
        assert _outcome(first_invalid_field, message) == want, values
        outcomes.add(want)
    assert None in outcomes  # valid messages were made
    assert len(outcomes) > 1  # and invalid ones


def _outcome(check: typing.Callable[[m.Message], str | None], message: m.Message) -> object:
    """What ``check`` says, or the type of what it raises (a value of a type no decoder
    makes can break a rule: then both must break alike)."""
    try:
        return check(message)
    except (TypeError, AttributeError, ValueError) as exc:
        return type(exc)
