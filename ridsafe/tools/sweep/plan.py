"""The experiment matrix as runs: one :class:`RunSpec` per cell, and what each one flies.

The matrix (:class:`~ridsafe.tools.sweep.config.SweepConfig`) is densities x seeds x planners
x every parameter axis (RSSI noise, alpha, ...); :func:`plan_sweep` turns it into a
:class:`SweepPlan` of :class:`RunSpec` (seed-major); :func:`scenario_for` is the scenario file a
spec flies, :func:`run_digest` its fingerprint (a result counts as finished, and a report uses
it, only while the config still gives the same digest).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import itertools
import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from typing import Any

from ridsafe import __version__
from ridsafe.common.config import to_mapping, with_overrides
from ridsafe.common.errors import RidsafeError
from ridsafe.tools.run.scenario import ScenarioFile, load_scenario_file, with_aircraft
from ridsafe.tools.sweep.config import ParamAxis, ParamValue, SweepConfig, format_value

__all__ = [
    "RunSpec",
    "SweepError",
    "SweepPlan",
    "check_plan",
    "load_sweep_file",
    "plan_sweep",
    "run_digest",
    "safe_run_digest",
    "scenario_for",
]

_Pairs = tuple[tuple[str, ParamValue], ...]


class SweepError(RidsafeError):
    """A sweep cannot start (e.g. DIR holds a sweep of another configuration)."""


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
