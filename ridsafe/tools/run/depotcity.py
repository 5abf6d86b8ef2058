"""The authors' per-run rules of their DepotCity scenario (``depotcity:`` in a scenario file).

``configs/paper_like.yaml`` lists the authors' 16 start points, their goal list and their
spoofer line (docs/paper_mode.md, "Sources": INI). Two things of their runs depend on the number
of aircraft N and the seed, and this module applies them when a file without a ``family`` is
sized to N aircraft (:func:`ridsafe.tools.run.scenario.with_aircraft`):

- **Goal reassignment** (their batch script, BATCH in docs/paper_mode.md). The first N goals
  are permuted among the first N aircraft: a permutation ``g`` (aircraft i flies to goal
  ``g[i]``) is drawn by shuffling ``[0, ..., N-1]`` with Python's Mersenne Twister seeded by the
  string ``key.format(aircraft=N, seed=seed)``, until every aircraft i has ``g[i] != i``, a
  horizontal start-to-goal length in [``min_leg_m``, ``max_leg_m``] and a leg passing within
  ``corridor_m[0]`` (horizontally) of the spoofer path's midpoint; ``attempts`` shuffles per
  stage, then the same with ``corridor_m[1]``, then ``fallback_attempts`` shuffles needing only
  ``g[i] != i``, and last the rotation ``g[i] = i + 1 mod N``. The generator is the same and
  is drawn in the same order as theirs, so seed s here is their seed s (the same goals).
  With 8 or more aircraft the two constrained stages almost never succeed: in effect their
  goals are a random derangement (docs/paper_mode.md, "Scenario rules").
- **Spoofer offset by N** (their INI): the offset its class claims depends on the scenario;
  ``spoofer_offsets_enu_m`` lists ``[N, east, north, up]`` rows, the row of N (if any)
  replacing ``scenario.spoofer.offset_enu_m``.

Our goals are on the ground (theirs airborne): the reassignment moves the goal's horizontal
position and keeps our altitudes.
"""

from __future__ import annotations

import dataclasses
import math
import random
from collections.abc import Sequence
from dataclasses import dataclass

from ridsafe.common.errors import FieldValueError
from ridsafe.common.scenario import Scenario

__all__ = ["DepotCityConfig", "apply_depotcity", "authors_goal_permutation"]

XY = tuple[float, float]


@dataclass(frozen=True)
class DepotCityConfig:
    """See the module docstring; the defaults are the authors' values (BATCH, INI)."""

    shuffle_goals: bool = True
    key: str = "Scenario_DepotCity_{aircraft}x1:{seed}:goal_shuffle_v2_constrained"
    min_leg_m: float = 320.0
    max_leg_m: float = 980.0
    corridor_m: tuple[float, float] = (260.0, 340.0)
    attempts: int = 768
    fallback_attempts: int = 256
    #: Rows [N, east, north, up] (m): the spoofer's claimed offset with N benign aircraft.
    spoofer_offsets_enu_m: tuple[tuple[float, float, float, float], ...] = ()

    def __post_init__(self) -> None:
        if not 0.0 <= self.min_leg_m <= self.max_leg_m:
            raise FieldValueError(
                "max_leg_m",
                f"expected 0 <= min_leg_m <= max_leg_m, got {self.min_leg_m}, {self.max_leg_m}",
            )
        if not 0.0 <= self.corridor_m[0] <= self.corridor_m[1]:
            raise FieldValueError(
                "corridor_m", f"expected 0 <= strict <= relaxed, got {self.corridor_m}"
            )
        if self.attempts < 0 or self.fallback_attempts < 0:
            raise FieldValueError("attempts", "expected attempts >= 0")
        for row in self.spoofer_offsets_enu_m:
            if row[0] < 1 or row[0] != int(row[0]):
                raise FieldValueError(
                    "spoofer_offsets_enu_m", f"expected rows [N >= 1, east, north, up], got {row}"
                )


def _distance_to_segment_m(p: XY, a: XY, b: XY) -> float:
    """Horizontal distance from ``p`` to the segment from ``a`` to ``b``."""
    ux, uy = b[0] - a[0], b[1] - a[1]
    length2 = ux * ux + uy * uy
    s = 0.0 if length2 <= 1e-9 else ((p[0] - a[0]) * ux + (p[1] - a[1]) * uy) / length2
    s = min(1.0, max(0.0, s))
    return math.hypot(p[0] - (a[0] + s * ux), p[1] - (a[1] + s * uy))


def authors_goal_permutation(
    starts_xy: Sequence[XY],
    goals_xy: Sequence[XY],
    hotspot_xy: XY | None,
    seed_text: str,
    cfg: DepotCityConfig,
) -> list[int]:
    """``g`` with aircraft i flying to goal ``g[i]`` (module docstring); deterministic in
    ``seed_text``."""
    n = len(starts_xy)
    rng = random.Random(seed_text)

    def fits(i: int, j: int, corridor_m: float | None) -> bool:
        if i == j:
            return False
        (sx, sy), (gx, gy) = starts_xy[i], goals_xy[j]
        if not cfg.min_leg_m <= math.hypot(gx - sx, gy - sy) <= cfg.max_leg_m:
            return False
        if corridor_m is None or hotspot_xy is None:
            return True
        return _distance_to_segment_m(hotspot_xy, (sx, sy), (gx, gy)) <= corridor_m

    for corridor_m in cfg.corridor_m:
        for _ in range(cfg.attempts):
            order = list(range(n))
            rng.shuffle(order)
            if all(fits(i, j, corridor_m) for i, j in enumerate(order)):
                return order
    for _ in range(cfg.fallback_attempts):
        order = list(range(n))
        rng.shuffle(order)
        if all(i != j for i, j in enumerate(order)):
            return order
    return [(i + 1) % n for i in range(n)]


def apply_depotcity(scenario: Scenario, cfg: DepotCityConfig) -> Scenario:
    """``scenario`` (already sized to its N aircraft) with the goals reassigned for its seed
    and the spoofer's offset for N."""
    aircraft = scenario.aircraft
    n = len(aircraft)
    spoofer = scenario.spoofer
    if cfg.shuffle_goals and n >= 2:
        hotspot: XY | None = None
        a_m = None if spoofer is None else spoofer.start_enu_m
        b_m = None if spoofer is None else spoofer.goal_enu_m
        if a_m is not None and b_m is not None:
            hotspot = (0.5 * (a_m[0] + b_m[0]), 0.5 * (a_m[1] + b_m[1]))
        order = authors_goal_permutation(
            [(a.start_enu_m[0], a.start_enu_m[1]) for a in aircraft],
            [(a.goal_enu_m[0], a.goal_enu_m[1]) for a in aircraft],
            hotspot,
            cfg.key.format(aircraft=n, seed=scenario.seed),
            cfg,
        )
        aircraft = tuple(
            dataclasses.replace(a, goal_enu_m=aircraft[j].goal_enu_m)
            for a, j in zip(aircraft, order, strict=True)
        )
    for row in cfg.spoofer_offsets_enu_m:
        if int(row[0]) == n and spoofer is not None:
            spoofer = dataclasses.replace(
                spoofer, offset_enu_m=(float(row[1]), float(row[2]), float(row[3]))
            )
    return dataclasses.replace(scenario, aircraft=aircraft, spoofer=spoofer)
