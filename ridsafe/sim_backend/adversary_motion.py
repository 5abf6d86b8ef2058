"""How spoofers really fly: the ``Mission`` of each motion kind (``ridsafe.common.adversary``).

Each gives the autopilot a position target and a velocity feed-forward in scenario ENU, so the
controller tracks the path (it avoids nobody):

- ``StraightLineMission`` (``ridsafe.sim_backend.spoofer``): a ``line``.
- ``WaypointPath``: piecewise-linear through the points at constant speed, holding the last one
  (or starting over when ``loop``); a ``line`` is the two-point path. Also what a ghost or a
  ``waypoints`` claim says it flies.
- ``OrbitMission``: a circle at constant speed, starting at the east of the circle.
- ``PursueMission``: flies at the target's true position (an attacker with eyes on it) at
  ``speed_m_s``, holding ``standoff_m`` short of it, never below ``MIN_PURSUE_ALT_M``. Its
  position target is a reference point that moves toward the target at ``speed_m_s`` (kept
  within ``PURSUE_LEAD_S`` of flight of the pursuer), so the pursuer flies at that speed: a
  target always one second ahead of the pursuer added the controller's position correction
  to the feed-forward, and a "6 m/s" pursuer flew at 8 m/s, as fast as the benign aircraft.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.adversary import MotionConfig
from ridsafe.sim_backend.spoofer import StraightLineMission

FloatArray = NDArray[np.float64]
MIN_PURSUE_ALT_M = 10.0
PURSUE_LEAD_S = 1.0  # the reference never leads the pursuer by more than this much flight


class WaypointPath:
    """Constant-speed piecewise-linear path through ``points`` from ``t0_s``."""

    def __init__(
        self,
        points: Sequence[Sequence[float]],
        speed_m_s: float,
        loop: bool = False,
        t0_s: float = 0.0,
    ) -> None:
        pts = [np.asarray(p, dtype=np.float64) for p in points]
        if loop and len(pts) > 1:
            pts.append(pts[0])
        self.points = np.array(pts)
        legs = np.linalg.norm(np.diff(self.points, axis=0), axis=1)
        self.cumulative_m = np.concatenate([[0.0], np.cumsum(legs)])
        self.length_m = float(self.cumulative_m[-1])
        self.speed_m_s = speed_m_s
        self.loop = loop
        self.t0_s = t0_s

    def target(self, now_s: float) -> tuple[FloatArray, FloatArray]:
        travelled = max(now_s - self.t0_s, 0.0) * self.speed_m_s
        if self.length_m <= 0.0:
            return self.points[0].copy(), np.zeros(3)
        if self.loop:
            travelled = math.fmod(travelled, self.length_m)
        elif travelled >= self.length_m:
            return self.points[-1].copy(), np.zeros(3)
        k = int(np.searchsorted(self.cumulative_m, travelled, side="right")) - 1
        k = min(max(k, 0), len(self.points) - 2)
        leg = self.points[k + 1] - self.points[k]
        leg_m = float(np.linalg.norm(leg))
        unit = leg / leg_m if leg_m > 0 else np.zeros(3)
        position: FloatArray = self.points[k] + (travelled - self.cumulative_m[k]) * unit
        velocity: FloatArray = self.speed_m_s * unit
        if now_s < self.t0_s:
            velocity = np.zeros(3)
        return position, velocity


class OrbitMission:
    """A circle of ``radius_m`` about ``centre_enu_m`` at ``speed_m_s``."""

    def __init__(
        self, centre_enu_m: Sequence[float], radius_m: float, speed_m_s: float, clockwise: bool
    ) -> None:
        self.centre = np.asarray(centre_enu_m, dtype=np.float64)
        self.radius_m = radius_m
        self.rate_rad_s = (-1.0 if clockwise else 1.0) * speed_m_s / radius_m

    def target(self, now_s: float) -> tuple[FloatArray, FloatArray]:
        angle = self.rate_rad_s * now_s
        c, s = math.cos(angle), math.sin(angle)
        position = self.centre + self.radius_m * np.array([c, s, 0.0])
        velocity = self.radius_m * self.rate_rad_s * np.array([-s, c, 0.0])
        return position, velocity


class PursueMission:
    """Toward the target's true position at ``speed_m_s``, ``standoff_m`` short of it
    (module docstring: a reference point moving at ``speed_m_s``)."""

    def __init__(
        self,
        own_position: Callable[[], FloatArray],
        target_position: Callable[[], FloatArray],
        speed_m_s: float,
        standoff_m: float,
    ) -> None:
        self.own_position = own_position
        self.target_position = target_position
        self.speed_m_s = speed_m_s
        self.standoff_m = standoff_m
        self._reference: FloatArray | None = None
        self._last_s: float | None = None

    def target(self, now_s: float) -> tuple[FloatArray, FloatArray]:
        own = np.asarray(self.own_position(), dtype=np.float64)
        goal = np.asarray(self.target_position(), dtype=np.float64).copy()
        goal[2] = max(goal[2], MIN_PURSUE_ALT_M)
        if self._reference is None or self._last_s is None:
            reference, dt_s = own.copy(), 0.0
        else:
            reference, dt_s = self._reference, max(now_s - self._last_s, 0.0)
        lead = reference - own  # the pursuer lags its reference by at most one lead
        max_lead_m = self.speed_m_s * PURSUE_LEAD_S
        if float(np.linalg.norm(lead)) > max_lead_m:
            reference = own + lead * (max_lead_m / float(np.linalg.norm(lead)))
        delta = goal - reference
        distance_m = float(np.linalg.norm(delta))
        to_go_m = distance_m - self.standoff_m
        velocity: FloatArray = np.zeros(3)
        if to_go_m > 0.0 and distance_m > 0.0:
            unit = delta / distance_m
            reference = reference + unit * min(self.speed_m_s * dt_s, to_go_m)
            velocity = unit * self.speed_m_s
        self._reference, self._last_s = reference, now_s
        return reference.copy(), velocity


Mission = StraightLineMission | WaypointPath | OrbitMission | PursueMission


def make_mission(
    motion: MotionConfig,
    own_position: Callable[[], FloatArray],
    target_position: Callable[[], FloatArray] | None,
) -> Mission:
    """The mission of ``motion`` (``target_position``: the pursued aircraft's true position)."""
    if motion.kind == "line":
        assert motion.start_enu_m is not None and motion.goal_enu_m is not None
        return StraightLineMission(motion.start_enu_m, motion.goal_enu_m, motion.speed_m_s)
    if motion.kind == "waypoints":
        assert motion.waypoints_enu_m is not None
        return WaypointPath(motion.waypoints_enu_m, motion.speed_m_s, bool(motion.loop))
    if motion.kind == "orbit":
        assert motion.centre_enu_m is not None and motion.radius_m is not None
        return OrbitMission(
            motion.centre_enu_m, motion.radius_m, motion.speed_m_s, bool(motion.clockwise)
        )
    assert target_position is not None
    return PursueMission(own_position, target_position, motion.speed_m_s, motion.standoff_m or 0.0)
