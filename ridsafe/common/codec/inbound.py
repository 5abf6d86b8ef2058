"""Validation at the edge: every field of every decoded inbound message, checked once.

``MavlinkLink.feed`` calls :func:`first_invalid_field` on each decoded domain message before
any core sees it; a message with a field no valid sender produces is dropped and counted by
``(message, field)`` (``LinkCounters.invalid_fields``, shown in every app's ``/app/counters``
as ``invalid.<MESSAGE>.<field>``). Cores may then convert with ``int()`` / ``struct`` without
guarding each value.

The rules, in order:

1. every ``float`` field (and every float inside a tuple field) is finite, except where
   MAVLink gives NaN a meaning: the COMMAND_LONG parameters a command does not use ("unset")
   and SET_POSITION_TARGET_LOCAL_NED's fields (NaN in fields the type mask ignores; the
   autopilot refuses, with a STATUSTEXT, a NaN in a field it uses); inf is refused
   everywhere;
2. the per-message bounds of ``_BOUNDS`` below (closed intervals; physical limits far beyond
   any aircraft this project flies, so a genuine sender never meets them):
   times (a UNIX time after 2100 or a boot time beyond the uint32 ms wrap), positions
   (|NED| <= 1,000 km, altitudes -1 km .. 100 km), speeds (<= 300 m/s), accelerations,
   covariances (>= 0 on the diagonal);
3. ``_COMMAND_PARAMS``: the parameters each handled MAV_CMD reads must be finite and, where
   the autopilot converts them to integers, inside that integer's range (DO_SET_MODE's
   base and custom modes are a uint8 and a uint32, message ids 24-bit). Ranges with a
   meaning (an arm parameter that is neither 0 nor 1, a take-off altitude of 600 m) are the
   autopilot's to refuse, with a COMMAND_ACK that says so;
4. ids (``uas_id``): printable ASCII.
"""

from __future__ import annotations

import functools
import math
import typing
from collections.abc import Callable
from dataclasses import fields

import numpy as np
from numpy.typing import NDArray

from ridsafe.common import messages as m
from ridsafe.common import protocol_messages as p
from ridsafe.common.jit import jit
from ridsafe.common.messages import FIRST_OPTIONAL_COLUMN

__all__ = ["first_invalid_field", "rows_valid"]

#: Latest plausible UNIX time (2100-01-01T00:00:00Z), seconds.
MAX_UNIX_TIME_S = 4_102_444_800.0
#: A boot time in a uint32 millisecond field wraps at 2**32 ms; more is impossible.
MAX_BOOT_TIME_S = 2**32 / 1000.0
MAX_DISTANCE_M = 1.0e6
MIN_ALT_M, MAX_ALT_M = -1.0e3, 1.0e5
MAX_SPEED_M_S = 300.0
MAX_ACCEL_M_S2 = 1.0e3
#: Times of the project's own messages (sim / autopilot clock seconds): within the boot clock.
MAX_MESSAGE_TIME_S = MAX_BOOT_TIME_S

Bound = tuple[str, float, float]  # (field, low, high); tuples: every element


def _norm_ok(values: tuple[float, ...], limit: float) -> bool:
    return math.sqrt(sum(v * v for v in values)) <= limit


_BOUNDS: dict[type, tuple[Bound, ...]] = {
    m.SystemTime: (("time_unix_s", 0.0, MAX_UNIX_TIME_S), ("time_boot_s", 0.0, MAX_BOOT_TIME_S)),
    m.SetPositionTargetLocalNed: (
        ("p_ned_m", -MAX_DISTANCE_M, MAX_DISTANCE_M),
        ("v_ned_m_s", -MAX_SPEED_M_S, MAX_SPEED_M_S),
        ("a_ned_m_s2", -MAX_ACCEL_M_S2, MAX_ACCEL_M_S2),
        ("yaw_rad", -100.0, 100.0),
        ("yaw_rate_rad_s", -100.0, 100.0),
    ),
    m.GlobalPositionInt: (
        ("alt_msl_m", MIN_ALT_M, MAX_ALT_M),
        ("relative_alt_m", MIN_ALT_M - MAX_ALT_M, MAX_ALT_M - MIN_ALT_M),
    ),
    m.LocalPositionNed: (
        ("p_ned_m", -MAX_DISTANCE_M, MAX_DISTANCE_M),
        ("v_ned_m_s", -MAX_SPEED_M_S, MAX_SPEED_M_S),
    ),
    m.HomePosition: (
        ("alt_msl_m", MIN_ALT_M, MAX_ALT_M),
        ("p_ned_m", -MAX_DISTANCE_M, MAX_DISTANCE_M),
    ),
    m.Observation: (
        ("t_s", 0.0, MAX_MESSAGE_TIME_S),
        ("rx_alt_m", MIN_ALT_M, MAX_ALT_M),
        ("claimed_alt_m", MIN_ALT_M, MAX_ALT_M),
        ("claimed_speed_horizontal_m_s", 0.0, MAX_SPEED_M_S),
        ("claimed_speed_vertical_m_s", -MAX_SPEED_M_S, MAX_SPEED_M_S),
    ),
    m.UnsafeRegionMsg: (
        ("t_s", 0.0, MAX_MESSAGE_TIME_S),
        ("valid_until_s", 0.0, MAX_MESSAGE_TIME_S),
        ("center_alt_m", MIN_ALT_M, MAX_ALT_M),
        ("v_ned_m_s", -MAX_SPEED_M_S, MAX_SPEED_M_S),
        ("chi2_threshold", 0.0, 1.0e6),
        ("alpha", 0.0, 1.0),
    ),
    m.SpoofAlert: (("t_s", 0.0, MAX_MESSAGE_TIME_S),),
}

_ID_FIELDS: dict[type, str] = {
    m.Observation: "uas_id",
    m.UnsafeRegionMsg: "uas_id",
    m.SpoofAlert: "uas_id",
}

_UINT32 = float(2**32 - 1)
#: Per handled command: the parameters (0-based) it reads and their closed ranges.
_COMMAND_PARAMS: dict[int, tuple[tuple[int, float, float], ...]] = {
    int(m.MavCmd.DO_SET_MODE): ((0, 0.0, 255.0), (1, 0.0, _UINT32)),
    int(m.MavCmd.COMPONENT_ARM_DISARM): ((0, -math.inf, math.inf), (1, -math.inf, math.inf)),
    int(m.MavCmd.NAV_TAKEOFF): ((6, -math.inf, math.inf),),
    int(m.MavCmd.SET_MESSAGE_INTERVAL): ((0, 0.0, 2.0**24), (1, -math.inf, math.inf)),
    int(m.MavCmd.REQUEST_MESSAGE): ((0, 0.0, 2.0**24),),
}


def _in_bounds(value: object, low: float, high: float) -> bool:
    if value is None:
        return True  # an "unknown" sentinel the codec mapped to None
    if isinstance(value, tuple):
        return all(_in_bounds(v, low, high) for v in value)
    if isinstance(value, float) and math.isnan(value):
        return True  # only where rule 1 let it through
    return isinstance(value, int | float) and low <= value <= high


@functools.cache
def _field_names(cls: type) -> tuple[str, ...]:
    return tuple(f.name for f in fields(cls))


def _non_finite_field(message: m.Message) -> str | None:
    cls: type = type(message)
    bad = math.isinf if cls in _NAN_MEANS_UNSET else _not_finite
    for name in _field_names(cls):
        value = getattr(message, name)
        if isinstance(value, float) and bad(value):
            return name
        if isinstance(value, tuple) and any(isinstance(v, float) and bad(v) for v in value):
            return name
    return None


def _not_finite(value: float) -> bool:
    return not math.isfinite(value)


#: Messages whose float fields may be NaN ("ignored") on the wire.
_NAN_MEANS_UNSET: frozenset[type] = frozenset({m.SetPositionTargetLocalNed})


def _command(message: m.CommandLong | p.CommandInt) -> str | None:
    """COMMAND_LONG and COMMAND_INT alike: a parameter the command does not read may be NaN
    (MAVLink's "unset", as MAVSDK sends), never infinite."""
    used = _COMMAND_PARAMS.get(message.command, ())
    for index, low, high in used:
        value = message.params[index]
        if not (math.isfinite(value) and low <= value <= high):
            return f"param{index + 1}"
    reads = {index for index, _, _ in used}
    for index, value in enumerate(message.params):
        if index not in reads and math.isinf(value):
            return f"param{index + 1}"
    return None


def _region(message: m.UnsafeRegionMsg) -> str | None:
    xx, _, _, yy, _, zz = message.cov_ned_m2
    if not (0.0 <= xx <= 1e12 and 0.0 <= yy <= 1e12 and 0.0 <= zz <= 1e12):
        return "cov_ned_m2"
    return None


def _rows(message: m.ObservationRows) -> str | None:
    return None if rows_valid(message) else "values"


_SPECIAL: dict[type, Callable[[m.Message], str | None]] = {
    m.CommandLong: _command,  # type: ignore[dict-item]
    p.CommandInt: _command,  # type: ignore[dict-item]
    m.UnsafeRegionMsg: _region,  # type: ignore[dict-item]
    m.ObservationRows: _rows,  # type: ignore[dict-item]
}


def first_invalid_field(message: m.Message) -> str | None:
    """The name of the first field of ``message`` no valid sender produces, or None."""
    cls: type = type(message)
    quick = _quick_check(cls)
    if quick is not None and quick(message):
        return None
    return _first_invalid_field_checked(message)


def rows_valid(rows: m.ObservationRows) -> bool:
    """True when ``first_invalid_field`` finds nothing in any row of ``rows`` (each row's
    ``Observation``): every value finite (NaN only where the row has None), inside
    ``_BOUNDS``, every id printable ASCII. False: check the rows one by one, which names the
    field."""
    return _rows_in_bounds(rows.values, *_OBSERVATION_COLUMN_BOUNDS) and all(
        text.isascii() and text.isprintable() for text in set(rows.uas_id)
    )


def _column_bounds(cls: type, columns: tuple[str, ...]) -> tuple[NDArray[np.float64], ...]:
    """(low, high) per column of ``_BOUNDS[cls]``, unbounded (+-inf) where it has none."""
    bounds = {name: (low, high) for name, low, high in _BOUNDS[cls]}
    low, high = zip(*(bounds.get(name, (-math.inf, math.inf)) for name in columns), strict=True)
    return np.array(low), np.array(high)


_OBSERVATION_COLUMN_BOUNDS = _column_bounds(m.Observation, m.OBSERVATION_COLUMNS)


@jit
def _rows_in_bounds(
    values: NDArray[np.float64], low: NDArray[np.float64], high: NDArray[np.float64]
) -> bool:
    """Rules 1 and 2 for every row: the columns before ``FIRST_OPTIONAL_COLUMN`` finite,
    the rest finite or NaN (None), each inside its bounds (NaN is)."""
    for r in range(values.shape[0]):
        for c in range(values.shape[1]):
            v = values[r, c]
            if np.isnan(v):
                if c < FIRST_OPTIONAL_COLUMN:
                    return False
            elif np.isinf(v) or v < low[c] or v > high[c]:
                return False
    return True


def _first_invalid_field_checked(message: m.Message) -> str | None:
    """``first_invalid_field`` by the rules one at a time, field by field (the reference)."""
    special = _SPECIAL.get(type(message))
    if special is not None:
        bad = special(message)
        if bad is not None:
            return bad
    if not isinstance(message, m.CommandLong | p.CommandInt | m.OdidRaw):
        bad = _non_finite_field(message)
        if bad is not None:
            return bad
    for name, low, high in _BOUNDS.get(type(message), ()):
        if not _in_bounds(getattr(message, name), low, high):
            return name
    id_field = _ID_FIELDS.get(type(message))
    if id_field is not None:
        text = getattr(message, id_field)
        if not (text.isascii() and text.isprintable()):
            return id_field
    return None


# -- the quick check: one generated expression per message class --------------------------
#
# Most messages are valid, and checking them field by field is a third of what decoding a
# packet costs. ``_quick_check(cls)`` is a function ``message -> bool`` generated from the
# class's field annotations: True only when every field holds exactly its annotated type
# (float, float | None, int, int | None, bool, str, bytes, a tuple of n floats), the sum of
# all its floats is finite (so each one is: a NaN or an inf anywhere makes the sum NaN or
# inf), every ``_BOUNDS`` interval holds and the id field is printable ASCII. That is the
# case where the rules above find nothing; a False (an unexpected type, a non-finite value,
# a sum that overflows, a bound missed) sends the message to the field-by-field rules,
# which then name the field. A class's special rule (``_SPECIAL``) is part of its quick
# check. Commands (NaN allowed where unused), raw ODID messages and classes with other field
# types have no quick check (None).

_SCALARS: dict[object, str] = {
    float: "type({v}) is float",
    float | None: "({v} is None or type({v}) is float)",
    int: "type({v}) is int",
    int | None: "({v} is None or type({v}) is int)",
    bool: "type({v}) is bool",
    str: "type({v}) is str",
    bytes: "type({v}) is bytes",
}


def _float_tuple_length(hint: object) -> int:
    """n for ``tuple[float, ...n times]``, else 0."""
    args = typing.get_args(hint)
    if typing.get_origin(hint) is tuple and args and all(a is float for a in args):
        return len(args)
    return 0


@functools.cache
def _quick_check(cls: type) -> Callable[[m.Message], bool] | None:
    """The generated quick check of ``cls`` (see above), or None."""
    if cls in (m.CommandLong, p.CommandInt, m.OdidRaw):  # rules of their own
        return None
    hints = typing.get_type_hints(cls)
    bounds = {name: (low, high) for name, low, high in _BOUNDS.get(cls, ())}
    guards, terms, ranges = [], [], []
    namespace: dict[str, object] = {"_isfinite": math.isfinite}
    for i, name in enumerate(_field_names(cls)):
        v, hint = f"v{i}", hints[name]
        low_high = bounds.get(name)
        n = _float_tuple_length(hint)
        if n:
            items = [f"{v}[{k}]" for k in range(n)]
            guards.append(f"type({v}) is tuple and len({v}) == {n}")
            guards += [f"type({item}) is float" for item in items]
            terms += items
            if low_high is not None:
                namespace[f"low{i}"], namespace[f"high{i}"] = low_high
                ranges += [f"low{i} <= {item} <= high{i}" for item in items]
            continue
        if hint not in _SCALARS:
            return None
        guards.append(_SCALARS[hint].format(v=v))
        if hint is float:
            terms.append(v)
        elif hint == float | None:
            terms.append(f"(0.0 if {v} is None else {v})")
        if low_high is not None:
            namespace[f"low{i}"], namespace[f"high{i}"] = low_high
            range_text = f"low{i} <= {v} <= high{i}"
            ranges.append(range_text if hint in (float, int) else f"({v} is None or {range_text})")
    id_field = _ID_FIELDS.get(cls)
    if id_field is not None:
        v = f"v{_field_names(cls).index(id_field)}"
        ranges.append(f"{v}.isascii() and {v}.isprintable()")
    finite = [f"_isfinite({' + '.join(terms)})"] if terms else []
    names = ", ".join(f"v{i}" for i in range(len(_field_names(cls))))
    getter = ", ".join(f"message.{name}" for name in _field_names(cls))
    special = _SPECIAL.get(cls)
    if special is not None:
        namespace["_special"] = special
        ranges.append("_special(message) is None")
    body = " and ".join(["True", *guards, *finite, *ranges])
    source = f"def quick(message):\n    {names}, = ({getter},)\n    return {body}\n"
    exec(compile(source, f"<quick check of {cls.__qualname__}>", "exec"), namespace)
    return namespace["quick"]  # type: ignore[return-value]
