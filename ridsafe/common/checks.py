"""Value checks shared by the frozen configuration dataclasses (their ``__post_init__``).

Each check raises :class:`~ridsafe.common.errors.FieldValueError` naming the field (the config
loader prefixes the file and key path) and saying what was expected and what came, e.g.
``FieldValueError("d_safe_m", "must be finite and > 0, got -5.0")``.

Numbers in a configuration are finite: the YAML loader already refuses ``.nan`` and ``.inf``;
these checks hold dataclasses built in code to the same rule.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable, Sequence

from ridsafe.common.errors import FieldValueError

__all__ = [
    "check_at_least",
    "check_covariance_diagonal",
    "check_cta2063_serial",
    "check_finite",
    "check_finite_vector",
    "check_in_interval",
    "check_increasing",
    "check_non_negative",
    "check_numeric_fields_positive",
    "check_positive",
    "check_positive_fields",
    "check_probability_vector",
]

#: A probability vector may miss 1 by this much (sums of decimal YAML values).
PROBABILITY_SUM_TOL = 1e-6


def check_finite(
    name: str,
    value: float,
    error: Callable[[str, str], Exception] = FieldValueError,
) -> None:
    """``value`` is a finite number; ``error(name, reason)`` is raised otherwise (a module
    with errors of its own, e.g. the clocks, passes a factory of those)."""
    if not math.isfinite(value):
        raise error(name, f"expected a finite number, got {value!r}")


def check_positive(name: str, value: float, *, may_be_zero: bool = False) -> None:
    """Finite and > 0 (>= 0 when ``may_be_zero``)."""
    ok = value >= 0.0 if may_be_zero else value > 0.0
    if not (math.isfinite(value) and ok):
        bound = ">= 0" if may_be_zero else "> 0"
        raise FieldValueError(name, f"must be finite and {bound}, got {value!r}")


def check_non_negative(name: str, value: float) -> None:
    """Finite and >= 0."""
    check_positive(name, value, may_be_zero=True)


def check_positive_fields(obj: object, *names: str, may_be_zero: Sequence[str] = ()) -> None:
    """:func:`check_positive` for each named field of ``obj``: ``names`` > 0, the fields in
    ``may_be_zero`` >= 0."""
    for name in names:
        check_positive(name, getattr(obj, name))
    for name in may_be_zero:
        check_positive(name, getattr(obj, name), may_be_zero=True)


def check_numeric_fields_positive(obj: object, may_be_zero: Sequence[str] = ()) -> None:
    """:func:`check_positive` for every int or float field of the dataclass ``obj`` (bools
    left out); the fields in ``may_be_zero`` may be 0."""
    for field in dataclasses.fields(obj):  # type: ignore[arg-type]
        value = getattr(obj, field.name)
        if isinstance(value, float | int) and not isinstance(value, bool):
            check_positive(field.name, value, may_be_zero=field.name in may_be_zero)


def check_at_least(name: str, value: int, minimum: int) -> None:
    """An integer count of at least ``minimum``."""
    if value < minimum:
        raise FieldValueError(name, f"expected >= {minimum}, got {value}")


def check_in_interval(name: str, value: float, low: float, high: float) -> None:
    """``low < value <= high``, and finite (``high`` may be ``math.inf``: no upper bound)."""
    if not (math.isfinite(value) and low < value <= high):
        raise FieldValueError(name, f"expected {low:g} < value <= {high:g}, got {value}")


def check_increasing(low_name: str, low: float, high_name: str, high: float) -> None:
    """Two finite bounds of a range, ``low < high``; the error names the lower one."""
    if not (math.isfinite(low) and math.isfinite(high) and low < high):
        raise FieldValueError(
            low_name, f"expected finite {low_name} < {high_name}, got {low}, {high}"
        )


def check_finite_vector(
    name: str, values: Sequence[float], limit: float = math.inf, unit: str = ""
) -> None:
    """Every element finite and within ``+/-limit``; the error names the element
    (``name[i]``). ``unit`` (e.g. ``" m"``) only decorates the message."""
    for i, value in enumerate(values):
        if not math.isfinite(value) or abs(value) > limit:
            within = "" if limit == math.inf else f" within +/-{limit:g}{unit}"
            raise FieldValueError(f"{name}[{i}]", f"expected a finite value{within}, got {value}")


def check_probability_vector(name: str, values: Sequence[float]) -> None:
    """Probabilities in [0, 1] that sum to 1 (within :data:`PROBABILITY_SUM_TOL`)."""
    for i, p in enumerate(values):
        if not 0.0 <= p <= 1.0:
            raise FieldValueError(f"{name}[{i}]", f"expected a probability in [0, 1], got {p}")
    total = math.fsum(values)
    if abs(total - 1.0) > PROBABILITY_SUM_TOL:
        raise FieldValueError(name, f"sums to {total:.6g}, must be 1")


def check_covariance_diagonal(
    name: str, values: Sequence[float], size: int, *, strictly_positive: bool = False
) -> None:
    """A covariance given by its diagonal: ``size`` finite values, PSD (>= 0), or PD (> 0)
    when ``strictly_positive``."""
    if len(values) != size:
        raise FieldValueError(name, f"expected {size} values, got {len(values)}")
    for i, v in enumerate(values):
        if not math.isfinite(v) or v < 0.0 or (strictly_positive and v == 0.0):
            bound = "> 0" if strictly_positive else ">= 0"
            raise FieldValueError(f"{name}[{i}]", f"covariance diagonal must be {bound}, got {v}")


# CTA-2063-A serial number: 4-character manufacturer code, one length character
# ('1'-'9', 'A'-'F' for 1-15) and the manufacturer's serial of that length. Digits and
# upper-case letters except O and I.
_CTA_CHARS = "0123456789ABCDEFGHJKLMNPQRSTUVWXYZ"
_CTA_RE = re.compile(rf"^[{_CTA_CHARS}]{{4}}[1-9A-F][{_CTA_CHARS}]{{1,15}}$")


def check_cta2063_serial(field: str, number: str) -> None:
    if not _CTA_RE.match(number) or int(number[4], 16) != len(number) - 5:
        raise FieldValueError(
            field,
            f"expected a CTA-2063-A serial (4-char maker code, length char, serial), "
            f"got {number!r}",
        )
