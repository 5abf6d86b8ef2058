"""Sweeps: the experiment matrix, one deterministic lockstep run per cell, and its folder.

The matrix (:class:`~ridsafe.tools.sweep_config.SweepConfig`) is densities x seeds x planners
x every parameter axis (RSSI noise, alpha, ...); each cell is a :class:`RunSpec`, flown by an
:class:`Engine` (:mod:`ridsafe.tools.sweep_engines`: a local process pool or Dask) and kept
under the sweep folder DIR::

    DIR/sweep.json, scenario.yaml        manifest (config, matrix) and the base scenario file
    DIR/n{density}/{planner}/seed{seed:03d}[/{axis}={value}...]/
        run.mcap     the run log
        result.json  status (completed / interrupted / failed and why), spec, run digest,
                     metrics (:func:`run_metrics` of run.mcap, a cache), wall clock, worker
        run.log      the run's warnings (kept out of the progress bar)

Resume: a spec whose result.json says completed for the same :func:`run_digest` (a fingerprint
of the scenario it flies) is skipped, so running the same command again finishes a sweep, and
after a config edit flies again only what the edit changes. A failed run is recorded and the
rest go on (:func:`run_sweep`).
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import hashlib
import itertools
import json
import logging
import os
import time
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import Any, Protocol

import yaml

from ridsafe import __version__
from ridsafe.common.config import to_mapping, with_overrides
from ridsafe.common.errors import RidsafeError
from ridsafe.tools.scenario import ScenarioFile, load_scenario_file, with_aircraft
from ridsafe.tools.sweep_config import (
    ParamAxis,
    ParamValue,
    SweepConfig,
    format_value,
    parse_seeds,
)

__all__ = [
    "LOG_FILE",
    "MANIFEST_FILE",
    "RESULT_FILE",
    "Engine",
    "ParamAxis",
    "ParamValue",
    "RunOutcome",
    "RunSpec",
    "RunStatus",
    "SweepConfig",
    "SweepError",
    "SweepObserver",
    "SweepPlan",
    "SweepSummary",
    "format_value",
    "load_sweep_file",
    "parse_seeds",
    "plan_sweep",
    "read_result",
    "run_digest",
    "run_metrics",
    "run_sweep",
    "safe_run_digest",
    "scenario_for",
]

logger = logging.getLogger(__name__)

LOG_FILE = "run.mcap"
RESULT_FILE = "result.json"
RUN_LOG_FILE = "run.log"
MANIFEST_FILE = "sweep.json"
SCENARIO_FILE = "scenario.yaml"


_Pairs = tuple[tuple[str, ParamValue], ...]
Metrics = dict[str, float | int | None]


class SweepError(RidsafeError):
    """A sweep cannot start (e.g. DIR holds a sweep of another configuration)."""


class RunStatus(enum.Enum):
    COMPLETED = "completed"
    INTERRUPTED = "interrupted"  # Ctrl-C during the run: the log is valid but short
    FAILED = "failed"  # raised, or its worker died: ``reason`` says why


# --------------------------------------------------------------------------------------------
# The matrix (its configuration: ``sweep_config.py``)


def load_sweep_file(
    path: str | Path, overrides: Mapping[str, object] | None = None
) -> tuple[ScenarioFile, SweepConfig]:
    """A scenario file with an optional ``sweep:`` section: (the scenario file with
    ``overrides`` applied and its matrix taken out, the matrix). Errors name the file and
    key path."""
    loaded = load_scenario_file(path, overrides)
    sweep = loaded.sweep if loaded.sweep is not None else SweepConfig()
    return dataclasses.replace(loaded, sweep=None), sweep


@dataclass(frozen=True)
class RunSpec:
    """One cell of the matrix; with the base scenario file it determines the run exactly."""

    density: int
    seed: int
    planner: str
    duration_s: float
    params: _Pairs = ()  # (axis name, value), in axis order
    overrides: _Pairs = ()  # (dotted key, value) the axes set

    @property
    def run_dir(self) -> PurePosixPath:
        """Relative folder: ``n16/aware/seed003[/alpha=0.1]``."""
        parts = [f"n{self.density}", self.planner, f"seed{self.seed:03d}"]
        parts += [f"{name}={format_value(value)}" for name, value in self.params]
        return PurePosixPath(*parts)

    @property
    def weight(self) -> float:
        """Relative cost (aircraft-seconds; measured: cost grows about linearly with both)."""
        return float(self.density) * self.duration_s

    def to_json(self) -> dict[str, object]:
        return {
            "density": self.density,
            "seed": self.seed,
            "planner": self.planner,
            "duration_s": self.duration_s,
            "params": [list(pair) for pair in self.params],
            "overrides": [list(pair) for pair in self.overrides],
        }

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> RunSpec:
        def pairs(key: str) -> _Pairs:
            return tuple((str(name), value) for name, value in data.get(key) or ())

        return cls(
            int(data["density"]),
            int(data["seed"]),
            str(data["planner"]),
            float(data["duration_s"]),
            pairs("params"),
            pairs("overrides"),
        )


@dataclass(frozen=True)
class SweepPlan:
    """Every spec of a sweep, in run order, and the base scenario file they apply to."""

    base: ScenarioFile
    config: SweepConfig
    source: str
    specs: tuple[RunSpec, ...]

    @functools.cached_property
    def digests(self) -> Mapping[RunSpec, str]:
        """Each spec's :func:`run_digest` ("" for a spec whose scenario cannot be built: it
        fails in its worker and is recorded)."""
        return {spec: safe_run_digest(self.base, spec) for spec in self.specs}

    def manifest(self) -> dict[str, object]:
        matrix = dataclasses.asdict(self.config)
        matrix["seeds"] = list(self.config.seed_values)
        matrix["duration_s"] = self.specs[0].duration_s if self.specs else None
        return {
            "config": self.source,
            "name": self.base.scenario.name,
            "matrix": matrix,
            "runs": len(self.specs),
            "ridsafe_version": __version__,
        }


def plan_sweep(base: ScenarioFile, config: SweepConfig, source: str = "") -> SweepPlan:
    """The matrix, seed-major (a partial sweep has whole matched seeds), largest density first
    within a seed (the pool's tail is short runs)."""
    duration = config.duration_s or base.scenario.duration_s
    run = dataclasses.replace(base.run, foxglove_channels=config.foxglove_channels)
    base = dataclasses.replace(base, run=run)
    specs = [
        RunSpec(density, seed, planner, duration, params, overrides)
        for seed in config.seed_values
        for density in sorted(config.densities, reverse=True)
        for planner in config.planners
        for params, overrides in _axis_cells(config.params)
    ]
    return SweepPlan(base, config, source, tuple(specs))


def _axis_cells(axes: Mapping[str, ParamAxis]) -> list[tuple[_Pairs, _Pairs]]:
    """Every combination of axis values: ((name, value) per axis, (key, value) per key)."""
    cells = []
    for values in itertools.product(*(axis.values for axis in axes.values())):
        chosen = list(zip(axes.items(), values, strict=True))
        params = tuple((name, value) for (name, _), value in chosen)
        overrides = tuple((key, value) for (_, axis), value in chosen for key in axis.keys)
        cells.append((params, overrides))
    return cells


def scenario_for(base: ScenarioFile, spec: RunSpec) -> ScenarioFile:
    """The scenario file a spec flies: axis overrides, then seed and duration, then the
    aircraft drawn for the seed (as ``ridsafe run --seed --duration --aircraft`` does)."""
    loaded = base
    if spec.overrides:
        loaded = with_overrides(base, dict(spec.overrides), source=f"sweep {spec.run_dir}")
    scenario = dataclasses.replace(loaded.scenario, seed=spec.seed, duration_s=spec.duration_s)
    return with_aircraft(dataclasses.replace(loaded, scenario=scenario), spec.density)


def run_digest(base: ScenarioFile, spec: RunSpec) -> str:
    """Fingerprint of what a spec flies (its whole scenario file and planner): a result counts
    as finished, and a report uses it, only while the config still gives the same digest. Edits
    that do not change the flown scenario (the aircraft a family redraws) keep it."""
    flown = {"scenario": to_mapping(scenario_for(base, spec)), "planner": spec.planner}
    return hashlib.sha256(json.dumps(flown, sort_keys=True).encode()).hexdigest()[:16]


def safe_run_digest(base: ScenarioFile, spec: RunSpec) -> str:
    """:func:`run_digest`, or "" when the spec's scenario cannot be built."""
    try:
        return run_digest(base, spec)
    except (RidsafeError, ValueError):
        return ""


def check_plan(plan: SweepPlan) -> None:
    """Build every spec's scenario (cheap) so a bad axis value fails before anything flies."""
    for spec in plan.specs:
        try:
            scenario_for(plan.base, spec)
        except (RidsafeError, ValueError) as err:
            raise SweepError(f"{spec.run_dir}: {err}") from err


# --------------------------------------------------------------------------------------------
# One run (in a worker)


def run_metrics(log_path: str | os.PathLike[str]) -> Metrics:
    """What a sweep records per run: the metrics of its log alone."""
    from ridsafe.tools.metrics import compute_metrics  # noqa: PLC0415

    return compute_metrics(log_path)


@dataclass(frozen=True)
class RunOutcome:
    """What a worker reports for one spec; ``log`` is the run.mcap when shipped back."""

    spec: RunSpec
    status: RunStatus
    reason: str
    metrics: Metrics
    wall_clock_s: float
    sim_time_s: float | None
    worker: str
    log_lines: tuple[str, ...] = ()
    log: bytes | None = field(default=None, repr=False)


# --------------------------------------------------------------------------------------------
# The sweep


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


def read_result(run_dir: Path) -> dict[str, Any] | None:
    """A run's result.json, or None when it has none (or an unreadable one)."""
    try:
        data = json.loads((run_dir / RESULT_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def is_finished(run_dir: Path, digest: str) -> bool:
    """Completed, for a scenario of this digest, and its log is there."""
    result = read_result(run_dir)
    return (
        bool(digest)
        and result is not None
        and result.get("status") == RunStatus.COMPLETED.value
        and result.get("run_digest") == digest
        and (run_dir / LOG_FILE).exists()
    )


def _write_atomic(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def record_outcome(out_dir: Path, plan: SweepPlan, outcome: RunOutcome, engine: str) -> Path:
    """Write the outcome's files (result.json last: it marks the run done)."""
    run_dir = out_dir / outcome.spec.run_dir
    run_dir.mkdir(parents=True, exist_ok=True)
    if outcome.log is not None:
        _write_atomic(run_dir / LOG_FILE, outcome.log)
    lines = "".join(f"{line}\n" for line in outcome.log_lines)
    _write_atomic(run_dir / RUN_LOG_FILE, lines.encode())
    log = run_dir / LOG_FILE
    result = {
        "status": outcome.status.value,
        "reason": outcome.reason,
        "spec": outcome.spec.to_json(),
        "config": plan.source,
        "run_digest": plan.digests.get(outcome.spec, ""),
        "metrics": outcome.metrics,
        "wall_clock_s": outcome.wall_clock_s,
        "sim_time_s": outcome.sim_time_s,
        "log_size_bytes": log.stat().st_size if log.exists() else None,
        "warnings": len(outcome.log_lines),
        "engine": engine,
        "worker": outcome.worker,
        "finished_unix_s": time.time(),
    }
    _write_atomic(run_dir / RESULT_FILE, (json.dumps(result, indent=2) + "\n").encode())
    return run_dir


def _prepare(out_dir: Path, plan: SweepPlan, engine: Engine) -> None:
    """Create DIR, refusing one that holds a sweep of another scenario (by name: a changed
    config of the same name re-flies the runs it changes)."""
    manifest_path = out_dir / MANIFEST_FILE
    if manifest_path.exists():
        old = json.loads(manifest_path.read_text(encoding="utf-8"))
        if old.get("name") != plan.base.scenario.name:
            raise SweepError(
                f"{out_dir} holds a sweep of scenario {old.get('name')!r} ({old.get('config')}), "
                f"not {plan.base.scenario.name!r}; choose another --out"
            )
    out_dir.mkdir(parents=True, exist_ok=True)
    manifest = {**plan.manifest(), "engine": engine.name, "workers": engine.workers}
    _write_atomic(manifest_path, (json.dumps(manifest, indent=2) + "\n").encode())
    text = yaml.safe_dump(to_mapping(plan.base), sort_keys=False)
    _write_atomic(out_dir / SCENARIO_FILE, text.encode())


class SweepObserver(Protocol):
    """What :func:`run_sweep` reports as it goes (the command line draws a progress bar)."""

    def start(self, specs: Sequence[RunSpec], todo: Sequence[RunSpec]) -> None: ...

    def finished(self, outcome: RunOutcome) -> None: ...


def run_sweep(
    plan: SweepPlan, out_dir: Path, engine: Engine, observer: SweepObserver | None = None
) -> SweepSummary:
    """Fly every spec of ``plan`` not yet finished in ``out_dir`` on ``engine``."""
    started = time.perf_counter()
    _prepare(out_dir, plan, engine)
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
