"""The planner as the companion drives it: what it is asked, when, and what is sent.

Every ``replan_period_s`` in CRUISE and DESCEND, ``PlannerDriver`` builds the
``PlannerInput`` (own position and velocity in the autopilot's local NED frame, the goal, the
neighbours from their Remote ID, the live unsafe regions), asks the planner, and sends its
target as SET_POSITION_TARGET_LOCAL_NED (position + velocity, type_mask 3520; position only,
3576, when the velocity is zero); in HOVER it holds the goal. Regions the GCS stopped
refreshing are held, inflated, when ``stale_region_hold_s`` > 0 (``stale_regions``). A
planner that raises or returns a non-finite target holds position instead, and the error is
logged and counted.
With ``ignore_grounded_traffic`` the neighbours that claim to stand on the ground (parked on
their pads, or delivered) are left out: they are no hazard to an aircraft in the air, and
among dense traffic the planner otherwise crawls past the aircraft parked at a depot. With
``landing_ignores_grounded_traffic`` (the default) the same in the descent onto the site
only: beside sites tens of metres apart the aircraft already delivered would otherwise keep
a landing aircraft d_safe away from its own. With
``traffic_gate.min_airborne`` > 0, once that many airborne aircraft are heard, only those on a
collision course or near are handed over (``traffic_gate``).
Every decision goes to ``/companion/decisions``. With ``pad_clearance_m`` > 0 it also tells
the mission what covers its pad before take-off and while descending (``pad_clearance``),
with the neighbours and regions the planner's policy lets in.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

from ridsafe.common import messages as m
from ridsafe.common import topics
from ridsafe.companion.config import AUTOPILOT_COMPONENT, CompanionConfig, CompanionSpec
from ridsafe.companion.events import CompanionLog
from ridsafe.companion.mission import Phase
from ridsafe.companion.mission_driver import MissionDriver
from ridsafe.companion.neighbours import NeighbourTable
from ridsafe.companion.pad_clearance import on_ground, pad_blocker
from ridsafe.companion.planner_api import (
    Planner,
    PlannerDecision,
    PlannerInput,
    PlannerStatus,
    Vec3,
)
from ridsafe.companion.regions import RegionStore
from ridsafe.companion.rid import Periodic
from ridsafe.companion.stale_regions import held_regions
from ridsafe.companion.telemetry import OwnTelemetry
from ridsafe.companion.traffic_gate import gate_neighbours

__all__ = ["PlannerCounters", "PlannerDriver"]

logger = logging.getLogger("ridsafe.companion.companion")

_ZERO: Vec3 = (0.0, 0.0, 0.0)
SendSetpoint = Callable[[m.SetPositionTargetLocalNed], None]


@dataclass
class PlannerCounters:
    decisions: int = 0
    planner_errors: int = 0
    plan_skipped: int = 0  # replan slots with no position or no home yet
    setpoints: int = 0


class PlannerDriver:
    """Asks ``planner`` for a target when one is due and sends it (module docstring)."""

    def __init__(
        self,
        spec: CompanionSpec,
        config: CompanionConfig,
        planner: Planner,
        own: OwnTelemetry,
        log: CompanionLog,
    ) -> None:
        self.spec = spec
        self.planner = planner
        self.own = own
        self.log = log
        self.counters = PlannerCounters()
        self.last_decision: PlannerDecision | None = None
        self._replan = Periodic(config.replan_period_s)
        self._hold_s = config.stale_region_hold_s
        self._growth_m2_s = config.stale_region_growth_m2_s
        self._pad_clearance_m = config.pad_clearance_m
        self._pad_lookahead_s = config.pad_lookahead_s
        self._pad_ceiling_m = config.pad_ceiling_m
        self._pad_timer = Periodic(config.replan_period_s)
        self._ignore_grounded = config.ignore_grounded_traffic
        self._landing_ignores_grounded = config.landing_ignores_grounded_traffic
        self._traffic_gate = config.traffic_gate
        self._cruise_speed_m_s = config.cruise_speed_m_s

    def step(
        self,
        now_s: float,
        mission: MissionDriver,
        neighbours: NeighbourTable,
        regions: RegionStore,
        send: SendSetpoint,
    ) -> None:
        phase = mission.phase
        if self._pad_check_due(now_s, mission):
            self._check_pad(now_s, mission, neighbours, regions)
        if phase not in _ACTIVE or not self._replan.due(now_s):
            return
        goal = mission.goal_local()
        if phase is Phase.HOVER:
            if goal is not None:
                send(self._target(now_s, goal, _ZERO))
            return
        lpn = self.own.lpn
        if lpn is None or goal is None:
            self.counters.plan_skipped += 1
            return
        sim_now = self.own.sim_time(now_s)
        to_local = self.own.to_local
        claims = neighbours.neighbours(sim_now, to_local, regions.flagged, self.own.local_frame)
        home = self.own.home
        descending = mission.descending()
        grounded_out = self._ignore_grounded or (descending and self._landing_ignores_grounded)
        if grounded_out and home is not None:
            claims = tuple(n for n in claims if not on_ground(n, home.p_ned_m[2]))
        if self._traffic_gate.enabled and home is not None:
            claims = gate_neighbours(
                sim_now, lpn.p_ned_m, lpn.v_ned_m_s, goal, claims, self._traffic_gate,
                self._cruise_speed_m_s, home.p_ned_m[2],
            )  # fmt: skip
        planner_input = PlannerInput(
            t_s=sim_now,
            p_ned_m=lpn.p_ned_m,
            v_ned_m_s=lpn.v_ned_m_s,
            goal_ned_m=goal,
            neighbours=claims,
            regions=tuple(
                r
                for r in regions.regions(sim_now, to_local)
                + held_regions(
                    regions.expired_last, sim_now, self._hold_s, self._growth_m2_s, to_local
                )
                if not r.on_ground  # a radio on the ground: only the pad rule minds it
            ),
            goal_any_height=mission.goal_any_height(),
            descend_to_goal=descending,
        )
        start = time.perf_counter()
        decision = self._decide(now_s, planner_input)
        compute_ms = (time.perf_counter() - start) * 1e3
        self.last_decision = decision
        self.counters.decisions += 1
        send(self._target(now_s, decision.target_p_ned_m, decision.target_v_ned_m_s))
        self._log_decision(planner_input, decision, compute_ms)

    def _pad_check_due(self, now_s: float, mission: MissionDriver) -> bool:
        if self._pad_clearance_m <= 0.0 or mission.phase not in _PAD_PHASES:
            return False
        if mission.phase is Phase.WAIT_DEPARTURE and self.own.sim_time(now_s) < (
            self.spec.departure_s
        ):
            return False
        return self._pad_timer.due(now_s)

    def _check_pad(
        self, now_s: float, mission: MissionDriver, neighbours: NeighbourTable, regions: RegionStore
    ) -> None:
        pad, policy = mission.pad_ned_m(), getattr(self.planner, "policy", None)
        if pad is None:
            return
        sim_now, to_local = self.own.sim_time(now_s), self.own.to_local
        use_regions = policy is not None and policy.use_regions
        trust_flagged = policy is None or policy.trust_flagged
        live = regions.regions(sim_now, to_local) if use_regions else ()
        region_ids = {r.uas_id for r in live}
        claims = tuple(
            n
            for n in neighbours.neighbours(sim_now, to_local, regions.flagged, self.own.local_frame)
            if trust_flagged or not (n.flagged or n.uas_id in region_ids)
        )
        ceiling_m = self._pad_ceiling_m
        lpn = self.own.lpn
        if mission.phase is Phase.DESCEND and lpn is not None:
            ceiling_m = pad[2] - lpn.p_ned_m[2]  # only aircraft below this one
        blocker = pad_blocker(
            pad, sim_now, claims, live, self._pad_clearance_m, self._pad_lookahead_s, ceiling_m
        )
        mission.set_pad_blocker(now_s, blocker)

    def _decide(self, now_s: float, planner_input: PlannerInput) -> PlannerDecision:
        """The planner's decision; on an exception or a non-finite target, hold position."""
        try:
            decision = self.planner.plan(planner_input)
            values = (*decision.target_p_ned_m, *decision.target_v_ned_m_s)
            if not all(math.isfinite(v) for v in values):
                raise ValueError(f"non-finite target {values}")
        except Exception as exc:  # a planner bug must not crash the aircraft's companion
            self.counters.planner_errors += 1
            logger.exception("companion %d: planner %s failed", self.spec.sysid, self.planner.name)
            self.log.event(now_s, "planner_error", repr(exc))
            return PlannerDecision(planner_input.p_ned_m, _ZERO, PlannerStatus.STUCK, None, "error")
        return decision

    def _target(self, now_s: float, p_ned_m: Vec3, v_ned_m_s: Vec3) -> m.SetPositionTargetLocalNed:
        mask = m.PositionTargetMask.POSITION_ONLY
        if any(v != 0.0 for v in v_ned_m_s):
            mask = m.PositionTargetMask.POSITION_VELOCITY
        self.counters.setpoints += 1
        return m.SetPositionTargetLocalNed(
            max(0.0, self.own.sim_time(now_s)), self.spec.sysid, AUTOPILOT_COMPONENT,
            int(m.MavFrame.LOCAL_NED), int(mask), p_ned_m, v_ned_m_s, _ZERO, 0.0, 0.0,
        )  # fmt: skip

    def _log_decision(
        self, planner_input: PlannerInput, decision: PlannerDecision, compute_ms: float
    ) -> None:
        lat, lon, alt = self.own.to_geodetic(decision.target_p_ned_m)
        record = {
            "sysid": self.spec.sysid,
            "planner": self.planner.name,
            "status": decision.status.value,
            "target_p_ned_m": list(decision.target_p_ned_m),
            "target_v_ned_m_s": list(decision.target_v_ned_m_s),
            "target_lat_deg": lat,
            "target_lon_deg": lon,
            "target_alt_m": alt,
            "compute_ms": compute_ms,
            "n_neighbours": len(planner_input.neighbours),
            "n_regions": len(planner_input.regions),
            "p_ned_m": list(planner_input.p_ned_m),
            "value": decision.value,
            "detail": decision.detail,
        }
        self.log.sink.log(topics.DECISIONS, planner_input.t_s, record)


_ACTIVE = frozenset({Phase.CRUISE, Phase.DESCEND, Phase.HOVER})
_PAD_PHASES = frozenset({Phase.WAIT_DEPARTURE, Phase.DESCEND})
