"""Tests for ridsafe.common.clock."""

from __future__ import annotations

import math
import time

import pytest

from ridsafe.common.clock import Clock, MonotonicClock, SimClock
from ridsafe.common.errors import ClockError, RidsafeError


class FakeTime:
    """A hand-cranked time source."""

    def __init__(self, t: float) -> None:
        self.t = t

    def __call__(self) -> float:
        return self.t


def test_sim_clock_starts_at_zero_and_moves_only_when_told() -> None:
    clock = SimClock()
    assert clock.now_s() == 0.0
    assert clock.now_s() == 0.0
    assert clock.advance(0.25) == 0.25
    clock.set(5.0)
    clock.set(5.0)  # staying put is allowed
    assert clock.now_s() == 5.0
    assert clock.advance(0.0) == 5.0
    assert SimClock(start_s=12.5).now_s() == 12.5


def test_sim_clock_refuses_to_go_backwards() -> None:
    clock = SimClock(start_s=3.0)
    with pytest.raises(ClockError, match=r"expected t_s >= 3\.0, got 2\.5"):
        clock.set(2.5)
    with pytest.raises(ClockError, match=r"expected dt_s >= 0, got -0\.1"):
        clock.advance(-0.1)
    assert clock.now_s() == 3.0  # unchanged after the refusals
    assert issubclass(ClockError, RidsafeError)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_sim_clock_refuses_non_finite_times(bad: float) -> None:
    clock = SimClock()
    with pytest.raises(ClockError, match="finite"):
        clock.set(bad)
    with pytest.raises(ClockError, match="finite"):
        clock.advance(bad)
    with pytest.raises(ClockError, match="finite"):
        SimClock(start_s=bad)


def test_set_from_tick_count_does_not_drift() -> None:
    stepped = SimClock()
    for _ in range(10):
        stepped.advance(0.1)
    assert stepped.now_s() != 1.0  # why the docstring says "set(k / rate_hz)"
    ticked = SimClock()
    for k in range(1, 11):
        ticked.set(k / 10)
    assert ticked.now_s() == 1.0


def test_monotonic_clock_scales_wall_time() -> None:
    fake = FakeTime(1000.0)
    clock = MonotonicClock(speed=4.0, time_source=fake)
    assert clock.now_s() == 0.0
    fake.t = 1000.5
    assert clock.now_s() == pytest.approx(2.0)
    assert clock.wall_delay_s(2.0) == pytest.approx(0.5)
    assert clock.wall_delay_s(-1.0) == 0.0
    assert clock.speed == 4.0


def test_monotonic_clock_with_the_real_time_source() -> None:
    clock = MonotonicClock()
    first = clock.now_s()
    time.sleep(0.02)
    second = clock.now_s()
    assert 0.0 <= first <= second
    assert 0.015 <= second < 1.0


@pytest.mark.parametrize("speed", [0.0, -1.0, math.nan, math.inf])
def test_monotonic_clock_rejects_bad_speed(speed: float) -> None:
    with pytest.raises(ClockError):
        MonotonicClock(speed=speed)


def test_both_clocks_satisfy_the_protocol() -> None:
    clocks: list[Clock] = [SimClock(), MonotonicClock()]
    assert all(isinstance(c, Clock) for c in clocks)
    assert not isinstance(object(), Clock)
