"""Flying a sweep: every spec of a plan not yet finished in its folder, on an engine.

:func:`run_sweep` prepares the folder (``sweep.folder``), skips finished runs, hands the rest
to an :class:`Engine` (``sweep.engines``: a local process pool or Dask) and records each
outcome as it comes. A failed run is recorded and the rest go on.
"""

from __future__ import annotations

import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from ridsafe.tools.run.scenario import ScenarioFile
from ridsafe.tools.sweep.folder import (
    RunOutcome,
    RunStatus,
    is_finished,
    prepare_folder,
    record_outcome,
)
from ridsafe.tools.sweep.plan import RunSpec, SweepPlan

__all__ = ["Engine", "SweepObserver", "SweepSummary", "run_sweep"]


class Engine(Protocol):
    """Runs specs somewhere and yields each outcome as soon as it is known (any order)."""

    name: str
    workers: int

    def run(
        self, base: ScenarioFile, specs: Sequence[RunSpec], out_dir: Path
    ) -> Iterator[RunOutcome]: ...


@dataclass(frozen=True)
class SweepSummary:
    total: int
    skipped: int  # finished before this call
    completed: int
    failed: tuple[RunOutcome, ...]  # failed or interrupted in this call
    wall_clock_s: float


class SweepObserver(Protocol):
    """What :func:`run_sweep` reports as it goes (the command line draws a progress bar)."""

    def start(self, specs: Sequence[RunSpec], todo: Sequence[RunSpec]) -> None: ...

    def finished(self, outcome: RunOutcome) -> None: ...


def run_sweep(
    plan: SweepPlan, out_dir: Path, engine: Engine, observer: SweepObserver | None = None
) -> SweepSummary:
    """Fly every spec of ``plan`` not yet finished in ``out_dir`` on ``engine``."""
    started = time.perf_counter()
    prepare_folder(out_dir, plan, engine.name, engine.workers)
    todo = [s for s in plan.specs if not is_finished(out_dir / s.run_dir, plan.digests[s])]
    if observer is not None:
        observer.start(plan.specs, todo)
    problems: list[RunOutcome] = []
    for outcome in engine.run(plan.base, todo, out_dir):
        record_outcome(out_dir, plan, outcome, engine.name)
        if outcome.status is not RunStatus.COMPLETED:
            problems.append(outcome)
        if observer is not None:
            observer.finished(outcome)
    wall = time.perf_counter() - started
    completed = len(todo) - len(problems)
    return SweepSummary(
        len(plan.specs), len(plan.specs) - len(todo), completed, tuple(problems), wall
    )
