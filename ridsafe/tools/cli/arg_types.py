"""Argument types that check numbers where they are parsed, so every error names its flag.

argparse reports a type's ``ArgumentTypeError`` as ``argument --duration: must be > 0, got
-5``, before any file is read or process started. The same holds for the other values a
flag carries: connection strings, integer lists, seed ranges (each type checks the text and
returns it unchanged, so what the command does with it is as before)."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

from ridsafe.common.errors import ConnectionStringError
from ridsafe.common.udp import parse_connection_string
from ridsafe.tools.sweep.config import parse_seeds

__all__ = [
    "connection_string",
    "finite_float",
    "int_list",
    "non_negative_int",
    "positive_float",
    "positive_int",
    "seed_list",
]


def _number(text: str, kind: Callable[[str], float]) -> float:
    try:
        value = kind(text)
    except ValueError:
        what = "an integer" if kind is int else "a number"
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be finite, got {text}")
    return value


def finite_float(text: str) -> float:
    return float(_number(text, float))


def positive_float(text: str) -> float:
    value = finite_float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return value


def positive_int(text: str) -> int:
    value = int(_number(text, int))
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {text}")
    return value


def non_negative_int(text: str) -> int:
    value = int(_number(text, int))
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {text}")
    return value


def connection_string(text: str) -> str:
    """A pymavlink-style connection string such as ``udpin:127.0.0.1:14450``, checked."""
    try:
        parse_connection_string(text)
    except ConnectionStringError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def int_list(text: str) -> str:
    """Comma-separated positive integers such as ``4,8,12``, checked."""
    for part in text.split(","):
        positive_int(part.strip())
    return text


def seed_list(text: str) -> str:
    """Seeds as ``0:30`` (start:stop) or ``0,1,5``, checked."""
    try:
        parse_seeds(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text
