"""The planner interface: what a companion hands its planner, and what it gets back.

Frames: everything is in the aircraft's local NED frame (the tangent frame at its home, the
frame of SET_POSITION_TARGET_LOCAL_NED), metres and m/s; times are sim seconds. The
companion converts RID positions (WGS-84) and unsafe regions (centre WGS-84, covariance in
NED axes) into this frame before planning; the planner never sees MAVLink or geodesy.

A planner is any object with ``name`` and ``plan(PlannerInput) -> PlannerDecision``; it may
keep memory between calls (e.g. progress tracking). Planners are registered by name in
``ridsafe.companion.planners.PLANNERS`` (``--planner NAME``).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Protocol

from ridsafe.common.frozen import quick_init

Vec3 = tuple[float, float, float]
Mat3 = tuple[Vec3, Vec3, Vec3]


@quick_init
@dataclass(frozen=True, slots=True)
class Neighbour:
    """Another aircraft as its Remote ID claims it (possibly a liar)."""

    uas_id: str
    p_ned_m: Vec3
    v_ned_m_s: Vec3
    t_s: float  # when the broadcast was received
    flagged: bool  # the GCS has raised a spoofing alert for this id


@dataclass(frozen=True, slots=True)
class Region:
    """Chance-constrained unsafe region: (x - c)^T P^-1 (x - c) <= chi2_threshold."""

    uas_id: str
    center_ned_m: Vec3
    cov_ned_m2: Mat3
    chi2_threshold: float
    v_ned_m_s: Vec3  # estimated velocity of the spoofer (to project the region)
    t_s: float  # time of the estimate
    valid_until_s: float
    #: A radio standing on the ground (the GCS's ``RegionFlags.ON_GROUND``): no hazard in
    #: flight, it holds only the take-offs and landings it covers (``pad_clearance``).
    on_ground: bool = False


@dataclass(frozen=True, slots=True)
class PlannerInput:
    t_s: float
    p_ned_m: Vec3  # own position
    v_ned_m_s: Vec3  # own velocity
    goal_ned_m: Vec3  # delivery point at cruise altitude
    neighbours: tuple[Neighbour, ...]
    regions: tuple[Region, ...]
    #: The goal counts as reached over it at any height (the mission's arrival before its
    #: descent, ``companion.arrival_alt_tolerance_m`` unset): the approach may keep the
    #: aircraft's height (``PlannerConfig.approach_level``).
    goal_any_height: bool = False
    #: The goal is the ground under the aircraft's site and it descends to it over the site
    #: (the mission's descent): the approach may descend straight onto it
    #: (``PlannerConfig.approach_descent``).
    descend_to_goal: bool = False


class PlannerStatus(enum.Enum):
    CRUISE = "cruise"
    ARRIVED = "arrived"
    AVOIDING = "avoiding"
    NO_SAFE_ACTION = "no_safe_action"
    STUCK = "stuck"


@dataclass(frozen=True, slots=True)
class PlannerDecision:
    """The setpoint to send (position with velocity feed-forward) and why."""

    target_p_ned_m: Vec3
    target_v_ned_m_s: Vec3
    status: PlannerStatus
    value: float | None = None  # value of the chosen action, when the planner has one
    detail: str = ""


class Planner(Protocol):
    name: str

    def plan(self, planner_input: PlannerInput) -> PlannerDecision: ...
