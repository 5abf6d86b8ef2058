"""Planners by name (``--planner NAME``), and the straight-line planner.

``PLANNERS`` maps a name to a factory ``(PlannerSettings) -> Planner``. ``PlannerSettings``
carries what the companion knows that a planner may need (cruise speed, replan period,
arrival radius, system id, seed) and the scenario file's ``planner:`` section
(``PlannerConfig``) for the MDP planners: ``aware`` (distrusts flagged RID, avoids unsafe
regions) and ``trust-rid`` (the paper's baseline: every RID position is true).

Straight line: fly the line from where the aircraft is to the goal at cruise speed (at most
8 m/s, the paper's limit), with a position target ``lookahead_s`` ahead on that line and the
velocity as feed-forward::

    u = (g - p) / |g - p|,   p* = p + min(V T, |g - p|) u,   v* = V u

Re-aiming from the current position each replan keeps it on the line despite disturbances.
Within ``approach_radius_m`` of the goal the target is the goal itself, position only
(v* = 0), so the autopilot brakes onto it along its own deceleration profile. It ignores
neighbours and regions: the baseline every avoiding planner must beat on NMACs.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field

from ridsafe.companion.config import MAX_AIRCRAFT_SPEED_M_S
from ridsafe.companion.planner import AwarePlanner, TrustRidPlanner
from ridsafe.companion.planner_api import (
    Planner,
    PlannerDecision,
    PlannerInput,
    PlannerStatus,
    Vec3,
)
from ridsafe.companion.planner_config import PlannerConfig

__all__ = ["PLANNERS", "PlannerSettings", "StraightLinePlanner", "make_planner"]


@dataclass(frozen=True)
class PlannerSettings:
    """What a planner factory gets."""

    sysid: int = 1
    cruise_speed_m_s: float = MAX_AIRCRAFT_SPEED_M_S
    replan_period_s: float = 0.5
    lookahead_s: float = 1.0
    approach_radius_m: float = 15.0
    arrival_radius_m: float = 10.0
    seed: int = 0
    config: PlannerConfig = field(default_factory=PlannerConfig)  # the ``planner:`` section


class StraightLinePlanner:
    """Target ``lookahead_s`` ahead on the line to the goal; see the module docstring."""

    name = "straight-line"

    def __init__(
        self,
        cruise_speed_m_s: float = MAX_AIRCRAFT_SPEED_M_S,
        lookahead_s: float = 1.0,
        approach_radius_m: float = 15.0,
        arrival_radius_m: float = 10.0,
    ) -> None:
        if not 0.0 < cruise_speed_m_s <= MAX_AIRCRAFT_SPEED_M_S:
            raise ValueError(
                f"cruise_speed_m_s: expected 0 < v <= {MAX_AIRCRAFT_SPEED_M_S}, "
                f"got {cruise_speed_m_s}"
            )
        if not (lookahead_s > 0.0 and approach_radius_m >= arrival_radius_m > 0.0):
            raise ValueError(
                "expected lookahead_s > 0 and approach_radius_m >= arrival_radius_m > 0, got "
                f"{lookahead_s}, {approach_radius_m}, {arrival_radius_m}"
            )
        self.cruise_speed_m_s = cruise_speed_m_s
        self.lookahead_s = lookahead_s
        self.approach_radius_m = approach_radius_m
        self.arrival_radius_m = arrival_radius_m

    def plan(self, planner_input: PlannerInput) -> PlannerDecision:
        p, g = planner_input.p_ned_m, planner_input.goal_ned_m
        d = (g[0] - p[0], g[1] - p[1], g[2] - p[2])
        distance = math.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2)
        if distance <= self.approach_radius_m:
            arrived = math.hypot(d[0], d[1]) <= self.arrival_radius_m
            status = PlannerStatus.ARRIVED if arrived else PlannerStatus.CRUISE
            return PlannerDecision(g, (0.0, 0.0, 0.0), status, detail="approach")
        u = (d[0] / distance, d[1] / distance, d[2] / distance)
        step = min(self.cruise_speed_m_s * self.lookahead_s, distance)
        target: Vec3 = (p[0] + step * u[0], p[1] + step * u[1], p[2] + step * u[2])
        v = self.cruise_speed_m_s
        return PlannerDecision(target, (v * u[0], v * u[1], v * u[2]), PlannerStatus.CRUISE)


def _straight_line(settings: PlannerSettings) -> Planner:
    return StraightLinePlanner(
        settings.cruise_speed_m_s,
        settings.lookahead_s,
        settings.approach_radius_m,
        settings.arrival_radius_m,
    )


def _mdp_config(settings: PlannerSettings) -> PlannerConfig:
    """The planner section with the companion's arrival radius and replan period, so the
    planner and the mission agree on when the aircraft has arrived."""
    return dataclasses.replace(
        settings.config,
        arrival_radius_m=settings.arrival_radius_m,
        replan_period_s=settings.replan_period_s,
    )


def _label(settings: PlannerSettings) -> str:
    """Who plans, in the planner's log lines (a lockstep run's companions share one log)."""
    return f"aircraft {settings.sysid}"


def _aware(settings: PlannerSettings) -> Planner:
    planner = AwarePlanner(_mdp_config(settings), _label(settings))
    planner.warm_up()  # compile (or load) the kernel now, not in the first decision
    return planner


def _trust_rid(settings: PlannerSettings) -> Planner:
    planner = TrustRidPlanner(_mdp_config(settings), _label(settings))
    planner.warm_up()
    return planner


PLANNERS: dict[str, Callable[[PlannerSettings], Planner]] = {
    StraightLinePlanner.name: _straight_line,
    "aware": _aware,
    "trust-rid": _trust_rid,
}


def make_planner(name: str, settings: PlannerSettings) -> Planner:
    """The planner registered as ``name``; KeyError listing the known names otherwise."""
    try:
        factory = PLANNERS[name]
    except KeyError:
        raise KeyError(f"unknown planner {name!r} (known: {', '.join(sorted(PLANNERS))})") from None
    return factory(settings)
