"""Clocks: where ``now_s`` comes from.

Cores never read the wall clock; a runner owns a :class:`Clock` and passes ``now_s`` in.

- :class:`SimClock`: sim time, set or advanced explicitly by the lockstep runner. Never goes
  backwards (raises :class:`~ridsafe.common.errors.ClockError`).
- :class:`MonotonicClock`: for the live UDP runner. ``now_s = speed * (monotonic() - t0)``,
  zero at construction; ``speed`` is sim seconds per wall second (2.0 = twice real time).

A lockstep runner stepping at ``rate_hz`` should ``set(k / rate_hz)`` from an integer tick
count rather than ``advance(1 / rate_hz)`` k times: repeated float addition drifts
(``sum([0.1] * 10) != 1.0``), and events scheduled "at t = 5 s" would then slip by a tick.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Protocol, runtime_checkable

from ridsafe.common.checks import check_finite
from ridsafe.common.errors import ClockError

__all__ = ["Clock", "MonotonicClock", "SimClock"]


@runtime_checkable
class Clock(Protocol):
    """Anything that tells the current time in seconds (sim time, non-decreasing)."""

    def now_s(self) -> float:
        """Seconds since the scenario started."""
        ...


class SimClock:
    """Sim time, moved only by its owner. Starts at ``start_s`` (default 0)."""

    def __init__(self, start_s: float = 0.0) -> None:
        _check_finite("start_s", start_s)
        self._now_s = float(start_s)

    def now_s(self) -> float:
        return self._now_s

    def set(self, t_s: float) -> None:
        """Jump to ``t_s``; equal to now is allowed, earlier raises ClockError."""
        _check_finite("t_s", t_s)
        if t_s < self._now_s:
            raise ClockError(f"SimClock.set: expected t_s >= {self._now_s!r}, got {t_s!r}")
        self._now_s = float(t_s)

    def advance(self, dt_s: float) -> float:
        """Move forward by ``dt_s >= 0`` and return the new time."""
        _check_finite("dt_s", dt_s)
        if dt_s < 0.0:
            raise ClockError(f"SimClock.advance: expected dt_s >= 0, got {dt_s!r}")
        self._now_s += float(dt_s)
        return self._now_s

    def __repr__(self) -> str:
        return f"SimClock(now_s={self._now_s!r})"


class MonotonicClock:
    """Wall-clock-driven sim time: ``speed * (time_source() - time_source() at construction)``.

    ``time_source`` defaults to :func:`time.monotonic`; tests inject a fake one.
    """

    def __init__(
        self, speed: float = 1.0, time_source: Callable[[], float] = time.monotonic
    ) -> None:
        _check_finite("speed", speed)
        if speed <= 0.0:
            raise ClockError(f"MonotonicClock: expected speed > 0, got {speed!r}")
        self._speed = float(speed)
        self._time_source = time_source
        self._t0 = time_source()

    @property
    def speed(self) -> float:
        """Sim seconds per wall second."""
        return self._speed

    def now_s(self) -> float:
        return (self._time_source() - self._t0) * self._speed

    def wall_delay_s(self, sim_dt_s: float) -> float:
        """Wall seconds to wait for ``sim_dt_s`` of sim time to pass (for a runner's sleep)."""
        return max(sim_dt_s, 0.0) / self._speed

    def __repr__(self) -> str:
        return f"MonotonicClock(speed={self._speed!r}, now_s={self.now_s()!r})"


def _clock_error(name: str, reason: str) -> ClockError:
    return ClockError(f"{name}: {reason}")


def _check_finite(name: str, value: float) -> None:
    check_finite(name, value, error=_clock_error)


class EpochClock:
    """Sim time that reads 0 at the UNIX instant ``t0_unix`` shared by every process of a
    live run: ``now_s = speed * (time_source() - t0_unix)`` (negative before it).

    ``time_source`` defaults to :func:`time.time` (the only clock processes share)."""

    def __init__(
        self, speed: float, t0_unix: float, time_source: Callable[[], float] = time.time
    ) -> None:
        if not (math.isfinite(speed) and speed > 0.0 and math.isfinite(t0_unix)):
            raise ClockError(
                f"EpochClock: expected speed > 0 and finite t0, got {speed}, {t0_unix}"
            )
        self.speed = float(speed)
        self.t0_unix = float(t0_unix)
        self._time_source = time_source

    def now_s(self) -> float:
        return (self._time_source() - self.t0_unix) * self.speed

    def wall_delay_s(self, sim_dt_s: float) -> float:
        return max(sim_dt_s, 0.0) / self.speed
