"""The FastMDP-style receding-horizon planners: ``aware`` and ``trust-rid``.

Every decision (the companion calls ``plan`` every ``replan_period_s`` = 0.5 s):

1. build the actions (headings x speeds x flight-path angles, climb, descend, hover:
   :mod:`.actions`) and roll each out over the horizon with the kinematic model (actions
   eq. 2), extended by a straight run at the goal to see what a region will still block;
2. project the hazards along the rollout times (:func:`.planner_eval.build_scene`): other
   aircraft along their RID velocity, unsafe regions along their estimated velocity, grown
   for prediction time (value eq. 5);
3. score every rollout (:mod:`.planner_eval`)::

       J_a = G_a + H_a + b sin(psi_a - psi_goal)     (goal, worst hazard, right-turn tie-break)

   and take the best action among the *safe* ones: no sample within ``region_margin_m`` of an
   unsafe region (action shielding, I_a = 0) and inside the altitude band (E_a);
4. fallback when no action is safe: the one with the least total intrusion into the regions
   (graded by the horizontal depth inside: the way out), ties by J_a; status ``NO_SAFE_ACTION``;
5. the setpoint is the chosen rollout's state a short time ahead (position at
   ``target_lead_s``, velocity at ``velocity_lead_s``; why in :mod:`.planner_config`), the
   velocity clipped to the flight envelope (|v| <= max speed, climb/descent limits; the ramp
   keeps |v* - v| <= accel_m_s2 x velocity_lead_s).

The two planners differ only in their :class:`RidPolicy`:

========== ================================== ===========================================
planner    neighbours flagged as spoofers      unsafe regions
========== ================================== ===========================================
aware      ignored (the region stands for      shielded against and penalised
           them; so is any id with a region)
trust-rid  ordinary aircraft at the claimed    ignored (the paper's baseline)
           position
========== ================================== ===========================================

Goal handling: within ``approach_radius_m``, with no hazard in play (status ``CRUISE``) or with
traffic about that stays ``approach_min_separation_m`` away while the aircraft holds here and no
region near, the setpoint is the goal itself (zero velocity): the autopilot's square-root shaper
brakes onto it, which no held-velocity action can among traffic. Where the goal is reached over
it at any height (``PlannerInput.goal_any_height``, with ``approach_level``), the radius is
horizontal and the setpoint the point over the goal at the aircraft's own height; where it
descends to the goal on the ground over its site (``PlannerInput.descend_to_goal``, with
``approach_descent``), the radius is horizontal and the setpoint the goal itself, provided
also no neighbour is predicted within ``approach_min_separation_m`` of the column it would
descend. Within
``arrival_radius_m`` (3-D) the aircraft is *arrived* (latched) and holds the goal (or lands)
unless an unsafe region engulfs it; then it evades and comes back. A progress watchdog reports
``STUCK`` (and logs a warning once) when the aircraft has not come ``stuck_progress_m`` closer
to its goal than ever before for ``stuck_after_s`` (counted afresh when the goal changes); it
keeps flying its best action meanwhile.

Deterministic: no randomness; ties between equal rollouts go to the right-hand turn.
"""

from __future__ import annotations

import itertools
import logging
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ridsafe.companion.actions import (
    ActionSet,
    build_action_set,
    clip_to_envelope,
    heading_to_rad,
    state_at,
)
from ridsafe.companion.planner_api import (
    Neighbour,
    PlannerDecision,
    PlannerInput,
    PlannerStatus,
    Region,
    Vec3,
)
from ridsafe.companion.planner_config import ArrivalAction, PlannerConfig
from ridsafe.companion.planner_eval import (
    KernelParams,
    RolloutScores,
    Scene,
    build_scene,
    score_actions,
)

__all__ = [
    "AWARE",
    "TRUST_RID",
    "AwarePlanner",
    "FastMdpPlanner",
    "ProgressWatchdog",
    "RidPolicy",
    "TrustRidPlanner",
    "choose_action",
]

FloatArray = NDArray[np.float64]
logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class RidPolicy:
    """How a planner treats Remote ID claims and unsafe regions."""

    name: str
    use_regions: bool  # shield against and penalise unsafe regions
    trust_flagged: bool  # treat flagged neighbours as ordinary aircraft at their claim


AWARE = RidPolicy("aware", use_regions=True, trust_flagged=False)
TRUST_RID = RidPolicy("trust-rid", use_regions=False, trust_flagged=True)


@dataclass
class ProgressWatchdog:
    """Says "stuck" once the distance to the goal has not beaten its best by ``progress_m``
    for ``after_s`` seconds. A new goal starts the count afresh: the best distance to the
    point over a delivery site says nothing of the descent to the ground under it."""

    after_s: float
    progress_m: float
    label: str = "planner"  # who is stuck, in the log (e.g. "aircraft 7")
    best_m: float = math.inf
    since_s: float | None = None
    stuck: bool = False
    goal_ned_m: Vec3 | None = None  # the goal best_m was measured to

    def update(self, now_s: float, goal_ned_m: Vec3, distance_m: float) -> bool:
        """Record the distance to ``goal_ned_m`` at ``now_s``; True while stuck."""
        if goal_ned_m != self.goal_ned_m:
            self.goal_ned_m, self.since_s = goal_ned_m, None
        if self.since_s is None or distance_m <= self.best_m - self.progress_m:
            self.best_m, self.since_s = distance_m, now_s
        was_stuck = self.stuck
        self.stuck = now_s - self.since_s >= self.after_s
        if self.stuck and not was_stuck:
            logger.warning(
                "%s: no progress toward the goal for %.0f s (%.0f m to go, best %.0f m)",
                self.label,
                now_s - self.since_s,
                distance_m,
                self.best_m,
            )
        elif was_stuck and not self.stuck:
            logger.info(
                "%s: progress toward the goal resumed (%.0f m to go)", self.label, distance_m
            )
        return self.stuck


def choose_action(
    scores: RolloutScores, actions: ActionSet, cfg: PlannerConfig
) -> tuple[int, PlannerStatus, float]:
    """(index, status, J) of the chosen action: best safe J, else least intrusion.

    Status: ``AVOIDING`` when a hazard term is active on the chosen rollout or the hazards
    changed the choice (the goal-only best differs), ``CRUISE`` otherwise, ``NO_SAFE_ACTION``
    when every rollout enters an unsafe region.
    """
    bias = cfg.right_turn_bias * actions.turn_right
    total = scores.goal + scores.hazard + bias
    safe = scores.envelope_ok & (scores.intrusion_m <= 0.0)
    if safe.any():
        index = int(np.argmax(np.where(safe, total, -np.inf)))
        free = int(np.argmax(np.where(scores.envelope_ok, scores.goal + bias, -np.inf)))
        avoiding = scores.hazard[index] < 0.0 or index != free
        status = PlannerStatus.AVOIDING if avoiding else PlannerStatus.CRUISE
        return index, status, float(total[index])
    pool = scores.envelope_ok if scores.envelope_ok.any() else np.ones(len(actions), bool)
    candidates = np.flatnonzero(pool)
    order = np.lexsort((-total[candidates], scores.intrusion_m[candidates]))
    index = int(candidates[order[0]])
    return index, PlannerStatus.NO_SAFE_ACTION, float(total[index])


#: One neighbour and one region that every rollout meets: what ``warm_up`` projects.
_WARM_UP_NEIGHBOURS = (Neighbour("warm-up", (50.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0, False),)
_WARM_UP_REGIONS = (
    Region(
        "warm-up",
        (80.0, 0.0, 0.0),
        ((100.0, 0.0, 0.0), (0.0, 100.0, 0.0), (0.0, 0.0, 100.0)),
        7.8,
        (0.0, 0.0, 0.0),
        0.0,
        1.0,
    ),
)


def _column_taken(scene: Scene, p0: FloatArray, goal: FloatArray, min_separation_m: float) -> bool:
    """Is a neighbour predicted within ``min_separation_m`` of the column the aircraft would
    descend, from its height straight down to ``goal``? (One landing at a site 30-40 m away
    is: hovering here may keep 60 m from it while it steers about, descending would not.)"""
    if not scene.nb_ids:
        return False
    q = scene.nb_pos_m  # (N, K, 3): every neighbour over the rollout's times
    horizontal = np.hypot(q[..., 0] - goal[0], q[..., 1] - goal[1])
    top, bottom = min(p0[2], goal[2]), max(p0[2], goal[2])
    vertical = np.clip(q[..., 2], top, bottom) - q[..., 2]
    return bool(np.any(np.hypot(horizontal, vertical) < min_separation_m))


def _finite(*vectors: Vec3) -> bool:
    return all(map(math.isfinite, itertools.chain.from_iterable(vectors)))


def _vec(x: FloatArray) -> Vec3:
    return (float(x[0]), float(x[1]), float(x[2]))


class FastMdpPlanner:
    """One aircraft's planner (keeps its arrival latch and progress watchdog between calls)."""

    def __init__(
        self, policy: RidPolicy, config: PlannerConfig | None = None, label: str | None = None
    ) -> None:
        """``label``: who plans, in the log lines (default the policy's name); the
        companions' factories name the aircraft, many of which share one process's log."""
        self.policy = policy
        self.name = policy.name
        self.label = policy.name if label is None else label
        self.config = config if config is not None else PlannerConfig()
        self._kernel_params = KernelParams.from_config(self.config)
        cfg = self.config
        self._watchdog = ProgressWatchdog(cfg.stuck_after_s, cfg.stuck_progress_m, self.label)
        self.arrived = False

    def warm_up(self) -> None:
        """Compile (or load from numba's on-disk cache) the rollout kernel now rather than in
        the first decision: about 0.2 s from the cache, several seconds cold. Leaves the
        planner's memory (arrival latch, watchdog) untouched."""
        cfg, origin = self.config, np.zeros(3)
        build_scene(0.0, origin, _WARM_UP_NEIGHBOURS, _WARM_UP_REGIONS, cfg)  # the scene kernels
        scene = build_scene(0.0, origin, (), (), cfg)
        actions = build_action_set(cfg, 0.0)
        kp, bias = self._kernel_params, cfg.right_turn_bias
        score_actions(origin, origin, origin + 1.0, actions, scene, kp, bias)

    def plan(self, planner_input: PlannerInput) -> PlannerDecision:
        cfg = self.config
        p0 = np.array(planner_input.p_ned_m, dtype=np.float64)
        v0 = np.array(planner_input.v_ned_m_s, dtype=np.float64)
        goal = np.array(planner_input.goal_ned_m, dtype=np.float64)
        distance = float(np.linalg.norm(goal - p0))
        if not self.arrived and distance <= cfg.arrival_radius_m:
            self.arrived = True
            logger.info("%s: arrived within %.1f m of the goal", self.label, distance)
        neighbours, regions = self._hazards(planner_input)
        scene = build_scene(planner_input.t_s, p0, neighbours, regions, cfg)
        actions = build_action_set(cfg, heading_to_rad(p0, goal))
        # Only the actions that can still be chosen are scored (choose_action's pick is the
        # same as from all of them: the bound argument of planner_kernel).
        scores = score_actions(
            p0, v0, goal, actions, scene, self._kernel_params, cfg.right_turn_bias
        )
        hover = len(actions) - 1
        if self.arrived and (scores.intrusion_m[hover] <= 0.0 or -p0[2] <= cfg.min_altitude_m):
            return self._arrival_decision(goal, scene)
        index, status, value = choose_action(scores, actions, cfg)
        stuck = self._watchdog.update(planner_input.t_s, planner_input.goal_ned_m, distance)
        horizontal_m = float(np.hypot(*(goal - p0)[:2]))
        descent = cfg.approach_descent and planner_input.descend_to_goal
        if cfg.approach_level and planner_input.goal_any_height:
            # brake onto the point over the goal, at the aircraft's height
            over_goal = np.array([goal[0], goal[1], p0[2]])
            point, point_m, what = over_goal, horizontal_m, "approach over the goal"
        elif descent:
            point, point_m, what = goal, horizontal_m, "descend onto the goal"
        else:
            point, point_m, what = goal, distance, "approach the goal"
        if (
            point_m <= cfg.approach_radius_m
            and self._clear_to_approach(status, scores, hover)
            and not (descent and _column_taken(scene, p0, goal, cfg.approach_min_separation_m))
        ):
            return PlannerDecision(_vec(point), (0.0, 0.0, 0.0), status, value, what)
        if stuck and status in (PlannerStatus.CRUISE, PlannerStatus.AVOIDING):
            status = PlannerStatus.STUCK
        p_in, v_in = planner_input.p_ned_m, planner_input.v_ned_m_s
        va = actions.velocity_ned_m_s[index].tolist()
        p_t, _ = state_at(p_in, v_in, va, cfg.target_lead_s, cfg.accel_m_s2)
        _, v_t = state_at(p_in, v_in, va, cfg.velocity_lead_s, cfg.accel_m_s2)
        detail = (
            f"{actions.describe(index)}; {len(scene.nb_ids)} aircraft, {len(scene.rg_ids)} "
            f"regions; closest predicted {scores.min_separation_m[index]:.0f} m"
        )
        v_target = clip_to_envelope(v_t, cfg)
        return PlannerDecision(p_t, _vec(v_target), status, value, detail)

    def _clear_to_approach(self, status: PlannerStatus, scores: RolloutScores, hover: int) -> bool:
        """Fly at the goal itself: nothing in play, or traffic about that keeps at least
        ``approach_min_separation_m`` while the aircraft stays here and no region near."""
        if status is PlannerStatus.CRUISE:
            return True
        return (
            status is PlannerStatus.AVOIDING
            and scores.intrusion_m[hover] <= 0.0
            and scores.min_separation_m[hover] >= self.config.approach_min_separation_m
        )

    def _hazards(
        self, planner_input: PlannerInput
    ) -> tuple[tuple[Neighbour, ...], tuple[Region, ...]]:
        """The neighbours and regions this planner's policy lets in (stale RID and regions
        with non-finite numbers dropped; ``build_scene`` never keeps a neighbour with one)."""
        now = planner_input.t_s
        regions = planner_input.regions if self.policy.use_regions else ()
        regions = tuple(r for r in regions if _finite(r.center_ned_m, r.v_ned_m_s, *r.cov_ned_m2))
        region_ids = {r.uas_id for r in regions if r.valid_until_s >= now}
        neighbours = tuple(
            n
            for n in planner_input.neighbours
            if now - n.t_s <= self.config.neighbour_max_age_s
            and (self.policy.trust_flagged or not (n.flagged or n.uas_id in region_ids))
        )
        return neighbours, regions

    def _arrival_decision(self, goal: FloatArray, scene: Scene) -> PlannerDecision:
        cfg = self.config
        target = goal.copy()
        if cfg.on_arrival is ArrivalAction.LAND:
            target[2] = cfg.ground_down_m
        return PlannerDecision(
            target_p_ned_m=_vec(target),
            target_v_ned_m_s=(0.0, 0.0, 0.0),
            status=PlannerStatus.ARRIVED,
            value=None,
            detail=f"{cfg.on_arrival.value} at the goal; {len(scene.nb_ids)} aircraft near",
        )


class AwarePlanner(FastMdpPlanner):
    """Spoofing-aware: distrusts flagged RID, shields against unsafe regions."""

    def __init__(self, config: PlannerConfig | None = None, label: str | None = None) -> None:
        super().__init__(AWARE, config, label)


class TrustRidPlanner(FastMdpPlanner):
    """The paper's baseline: every RID claim is true, unsafe regions are ignored."""

    def __init__(self, config: PlannerConfig | None = None, label: str | None = None) -> None:
        super().__init__(TRUST_RID, config, label)
