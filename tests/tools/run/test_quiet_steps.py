"""The split run's worker answers for the GCS's quiet steps before it runs them and runs them
later a datagram at a time (``lockstep_split._QuietSteps``): the core gets the calls
``handle`` would make, in the same order; a quiet step that sends or logs is an error."""

from __future__ import annotations

import pytest

from ridsafe.common.shell import Datagrams
from ridsafe.tools.run.lockstep_split import LaneBuffer, StepsInParts, _QuietSteps


class _Recording:
    """A core in parts that records its calls; quiet at the times in ``quiet``."""

    def __init__(self, quiet: set[float], sends_at: float | None = None) -> None:
        self.quiet = quiet
        self.sends_at = sends_at
        self.calls: list[tuple[str, float, Datagrams]] = []

    def begin(self, now_s: float) -> None:
        self.calls.append(("begin", now_s, []))

    def receive(self, now_s: float, inbound: Datagrams) -> None:
        self.calls.append(("receive", now_s, list(inbound)))

    def tick(self, now_s: float) -> Datagrams:
        self.calls.append(("tick", now_s, []))
        return [("c1", b"x")] if now_s == self.sends_at else []

    def quiet_at(self, now_s: float) -> bool:
        return now_s in self.quiet


def test_quiet_steps_run_later_in_order_as_handle_would_run_them() -> None:
    core = _Recording(quiet={0.05, 0.10})
    assert isinstance(core, StepsInParts)
    steps = _QuietSteps(core, LaneBuffer())
    a, b, c = ("companions@c1", b"a"), ("companions@c2", b"b"), ("companions@c1", b"c")
    assert steps.defer(0.05, [a, b]) and steps.defer(0.10, [c])
    assert not steps.defer(0.15, [a])  # not quiet: the caller runs it, after run_all
    assert core.calls == []  # answered for, not run yet
    assert steps.run_one() and core.calls == [("begin", 0.05, [])]
    steps.run_all()
    assert core.calls == [
        ("begin", 0.05, []),
        ("receive", 0.05, [a]),
        ("receive", 0.05, [b]),
        ("tick", 0.05, []),
        ("begin", 0.10, []),
        ("receive", 0.10, [c]),
        ("tick", 0.10, []),
    ]
    assert not steps.run_one() and not steps.pending


def test_a_quiet_step_that_sends_or_logs_is_an_error() -> None:
    steps = _QuietSteps(_Recording(quiet={0.05}, sends_at=0.05), LaneBuffer())
    steps.defer(0.05, [])
    with pytest.raises(RuntimeError, match="sent"):
        steps.run_all()

    buffer = LaneBuffer()

    class _Logging(_Recording):
        def receive(self, now_s: float, inbound: Datagrams) -> None:
            buffer.log("/gcs/cycle", now_s, {})

    steps = _QuietSteps(_Logging(quiet={0.05}), buffer)
    steps.defer(0.05, [("companions@c1", b"a")])
    with pytest.raises(RuntimeError, match="logged"):
        steps.run_all()
