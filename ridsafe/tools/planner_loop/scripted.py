"""Small scripted encounters for planner tests: planners flown against each other and a
straight-line spoofer whose region is centred on its truth (no estimation error)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ridsafe.companion.planner import FastMdpPlanner
from ridsafe.companion.planner_api import Neighbour, PlannerInput, PlannerStatus, Region
from ridsafe.tools.planner_loop.fleets import KinematicFleet
from ridsafe.tools.planner_loop.layout import SPOOFER_ID, t3

__all__ = ["Encounter", "ScriptedSpoofer", "fly"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class ScriptedSpoofer:
    """A spoofer on a straight line; its region is centred on the truth (no estimation error)."""

    start_ned_m: tuple[float, float, float]
    v_ned_m_s: tuple[float, float, float] = (0.0, 0.0, 0.0)
    offset_ned_m: tuple[float, float, float] = (50.0, 50.0, 0.0)
    cov_ned_m2: tuple[float, float, float] = (400.0, 400.0, 1600.0)  # diagonal
    chi2_threshold: float = 7.814727903251178

    def state(self, t_s: float) -> tuple[FloatArray, FloatArray]:
        v = np.asarray(self.v_ned_m_s)
        return np.asarray(self.start_ned_m) + v * t_s, v

    def rid(self, t_s: float) -> Neighbour:
        p, v = self.state(t_s)
        return Neighbour(SPOOFER_ID, t3(p + np.asarray(self.offset_ned_m)), t3(v), t_s, True)

    def region(self, t_s: float) -> Region:
        p, v = self.state(t_s)
        c = self.cov_ned_m2
        cov = ((c[0], 0.0, 0.0), (0.0, c[1], 0.0), (0.0, 0.0, c[2]))
        return Region(SPOOFER_ID, t3(p), cov, self.chi2_threshold, t3(v), t_s, t_s + 1.0)


@dataclass(frozen=True)
class Encounter:
    """Positions ``(T, N, 3)`` of the aircraft and ``(T, 3)`` of the spoofer, every ``dt_s``."""

    p_ned_m: FloatArray
    spoofer_ned_m: FloatArray
    statuses: list[list[PlannerStatus]]  # per decision, per aircraft

    def min_separation_m(self) -> float:
        p = self.p_ned_m
        d = np.linalg.norm(p[:, :, None, :] - p[:, None, :, :], axis=-1)
        d[:, np.arange(p.shape[1]), np.arange(p.shape[1])] = np.inf
        return float(d.min())

    def min_spoofer_distance_m(self) -> float:
        return float(np.linalg.norm(self.p_ned_m - self.spoofer_ned_m[:, None, :], axis=-1).min())


def fly(
    planners: list[FastMdpPlanner],
    starts: list[tuple[float, float, float]],
    goals: list[tuple[float, float, float]],
    duration_s: float,
    spoofer: ScriptedSpoofer | None = None,
    dt_s: float = 0.05,
) -> Encounter:
    """Fly ``planners`` (kinematic aircraft, replanning every 0.5 s, neighbours' true states)
    against each other and an optional spoofer (RID flagged, region on the truth)."""
    fleet = KinematicFleet(np.asarray(starts, dtype=np.float64))
    n = len(planners)
    track, spoofer_track, statuses = [], [], []
    for step in range(round(duration_s / dt_s)):
        t = step * dt_s
        if step % round(0.5 / dt_s) == 0:
            row = []
            for i, planner in enumerate(planners):
                nbs = [
                    Neighbour(f"B{j}", t3(fleet.p[j]), t3(fleet.v[j]), t, False)
                    for j in range(n)
                    if j != i
                ]
                regions: tuple[Region, ...] = ()
                if spoofer is not None:
                    nbs.append(spoofer.rid(t))
                    regions = (spoofer.region(t),)
                inp = PlannerInput(t, t3(fleet.p[i]), t3(fleet.v[i]), goals[i], tuple(nbs), regions)
                decision = planner.plan(inp)
                row.append(decision.status)
                fleet.set_target(
                    i, np.asarray(decision.target_p_ned_m), np.asarray(decision.target_v_ned_m_s)
                )
            statuses.append(row)
        fleet.step(dt_s)
        track.append(fleet.p.copy())
        spoofer_track.append(
            spoofer.state(t + dt_s)[0] if spoofer is not None else np.full(3, np.inf)
        )
    return Encounter(np.asarray(track), np.asarray(spoofer_track), statuses)
