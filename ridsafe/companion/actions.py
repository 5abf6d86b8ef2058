"""The planner's actions (motion primitives) and their kinematic rollouts.

An action is a heading psi (clockwise from north), a speed V and a flight-path angle gamma
(> 0 climbs), held over the horizon. In the aircraft's local NED frame::

    v_a = V (cos gamma cos psi, cos gamma sin psi, -sin gamma)                          (1)
    v_a,down  clipped to  [-max_climb, +max_descent]      (the autopilot's vertical limits)

Headings: ``n_headings`` absolute ones (psi_i = 2 pi i / n) and goal-relative ones
(psi_goal + offset), so flying straight at the goal is always an action. Then three more:
climb straight up at max_climb, descend straight down at max_descent (gamma = +/-90 deg, so an
aircraft above or below its goal can reach it) and hover (v_a = 0), always the last action.

Rollout model: from the current velocity v0 the aircraft ramps its velocity to v_a at a
constant acceleration a (the autopilot's cascade reaches a commanded velocity this way when
its tilt limit binds), then holds it::

    dv = v_a - v0,   t_r = |dv| / a,   u = dv / |dv|
    v(tau) = v0 + a u tau,              p(tau) = p0 + v0 tau + a u tau^2 / 2      tau <= t_r
    v(tau) = v_a,                       p(tau) = p(t_r) + v_a (tau - t_r)           tau >  t_r  (2)

Along the ramp v(tau) is a convex combination of v0 and v_a, so |v(tau)| <= max(|v0|, |v_a|)
and the down speed stays between theirs; |dv/dtau| = a <= g tan(max_tilt) keeps it flyable.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ridsafe.companion.planner_api import Vec3
from ridsafe.companion.planner_config import PlannerConfig

__all__ = [
    "ActionSet",
    "build_action_set",
    "clip_to_envelope",
    "heading_to_rad",
    "rollout",
    "state_at",
]

FloatArray = NDArray[np.float64]

_TINY_M = 1e-9


@dataclass(frozen=True)
class ActionSet:
    """The actions of one decision; A = ``len(self)``; the last three are climb, descend, hover.

    ``velocity_ned_m_s : (A, 3)`` is eq. (1) after the vertical clip; ``turn_right : (A,)``
    is sin(psi_a - psi_goal) (> 0: right of the goal line; 0 for the last three), used to
    break ties the same way on every aircraft (a head-on pair both turn right, as the rules of
    the air say).
    """

    heading_rad: FloatArray
    speed_m_s: FloatArray
    fpa_rad: FloatArray
    velocity_ned_m_s: FloatArray
    turn_right: FloatArray

    def __len__(self) -> int:
        return int(self.heading_rad.shape[0])

    def describe(self, index: int) -> str:
        """``"heading 45 deg, 8.0 m/s, fpa +2.9 deg"`` (or ``"hover"``) for logs."""
        if self.speed_m_s[index] == 0.0:
            return "hover"
        if abs(self.fpa_rad[index]) >= math.pi / 2:
            verb = "climb" if self.fpa_rad[index] > 0 else "descend"
            return f"{verb} {self.speed_m_s[index]:.1f} m/s"
        heading = math.degrees(self.heading_rad[index]) % 360.0
        fpa = math.degrees(self.fpa_rad[index])
        return f"heading {heading:.0f} deg, {self.speed_m_s[index]:.1f} m/s, fpa {fpa:+.1f} deg"


def heading_to_rad(p_ned_m: ArrayLike, goal_ned_m: ArrayLike) -> float:
    """Heading (rad, clockwise from north) of the horizontal line to the goal; 0 when above it."""
    p = np.asarray(p_ned_m, dtype=np.float64)
    g = np.asarray(goal_ned_m, dtype=np.float64)
    dn, de = float(g[0] - p[0]), float(g[1] - p[1])
    if math.hypot(dn, de) < _TINY_M:
        return 0.0
    return math.atan2(de, dn)


def build_action_set(cfg: PlannerConfig, goal_heading_rad: float) -> ActionSet:
    """All actions of one decision: headings x speeds x flight-path angles, climb, descend,
    hover."""
    template = _template(cfg)
    horizontal = template.horizontal_m_s
    relative = (goal_heading_rad + template.offsets_rad)[:, None]  # (H_rel, 1)
    first, last = template.n_absolute, len(template.speeds) - 3  # the goal-relative rows
    velocity = template.velocity.copy()
    velocity[first:last, 0] = (horizontal * np.cos(relative)).ravel()
    velocity[first:last, 1] = (horizontal * np.sin(relative)).ravel()
    psi = template.psi.copy()
    psi[first:last] = np.repeat(relative[:, 0], horizontal.shape[0])
    psi[last:] = goal_heading_rad
    turn = np.zeros(psi.shape[0])
    turn[:last] = np.sin(psi[:last] - goal_heading_rad)
    return ActionSet(psi, template.speeds, template.gammas, velocity, turn)


@dataclass(frozen=True)
class _Template:
    """What of an action set does not depend on the goal: every row of the absolute headings,
    the last three (climb, descend, hover), every action's V and gamma; the goal-relative
    headings' offsets (rad) and the horizontal speed V cos gamma of each (speed, angle) pair.
    ``n_absolute``: rows of the absolute headings (they come first)."""

    n_absolute: int
    offsets_rad: FloatArray
    horizontal_m_s: FloatArray
    velocity: FloatArray
    psi: FloatArray
    speeds: FloatArray
    gammas: FloatArray


@functools.lru_cache(maxsize=16)
def _template(cfg: PlannerConfig) -> _Template:
    absolute_rad, horizontal, down, speed, gamma = _primitives(cfg)
    offsets_rad = np.radians(np.asarray(cfg.goal_heading_offsets_deg, dtype=np.float64))
    n_headings = absolute_rad.shape[0] + offsets_rad.shape[0]
    n_absolute = absolute_rad.shape[0] * horizontal.shape[0]
    n = n_headings * horizontal.shape[0] + 3
    absolute = absolute_rad[:, None]
    velocity = np.zeros((n, 3))
    velocity[:n_absolute, 0] = (horizontal * np.cos(absolute)).ravel()
    velocity[:n_absolute, 1] = (horizontal * np.sin(absolute)).ravel()
    velocity[:-3, 2] = np.broadcast_to(down, (n_headings, down.shape[0])).ravel()
    velocity[-3:] = ((0.0, 0.0, -cfg.max_climb_m_s), (0.0, 0.0, cfg.max_descent_m_s), (0, 0, 0))
    psi = np.zeros(n)
    psi[:n_absolute] = np.repeat(absolute_rad, horizontal.shape[0])
    vertical_speeds = (cfg.max_climb_m_s, cfg.max_descent_m_s, 0.0)
    speeds = np.concatenate([np.tile(speed, n_headings), vertical_speeds])
    gammas = np.concatenate([np.tile(gamma, n_headings), (np.pi / 2, -np.pi / 2, 0.0)])
    for part in (offsets_rad, velocity, psi, speeds, gammas):
        part.setflags(write=False)
    return _Template(n_absolute, offsets_rad, horizontal, velocity, psi, speeds, gammas)


@functools.lru_cache(maxsize=16)
def _primitives(
    cfg: PlannerConfig,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """What does not depend on the goal: the absolute headings (rad), and per (speed, angle)
    pair, speed-major, eq. (1)'s horizontal speed V cos gamma, its clipped down speed, V and
    gamma (rad)."""
    absolute = 2.0 * np.pi * np.arange(cfg.n_headings) / cfg.n_headings
    grid = np.meshgrid(
        np.asarray(cfg.speeds_m_s, dtype=np.float64),
        np.radians(np.asarray(cfg.flight_path_angles_deg, dtype=np.float64)),
        indexing="ij",
    )
    speed, gamma = grid[0].ravel(), grid[1].ravel()
    down = np.clip(-speed * np.sin(gamma), -cfg.max_climb_m_s, cfg.max_descent_m_s)
    parts = (absolute, speed * np.cos(gamma), down, speed, gamma)
    for part in parts:
        part.setflags(write=False)
    return parts


def rollout(
    p0_m: ArrayLike, v0_m_s: ArrayLike, va_m_s: ArrayLike, tau_s: ArrayLike, accel_m_s2: float
) -> tuple[FloatArray, FloatArray]:
    """Eq. (2): positions and velocities ``(..., K, 3)`` of actions ``va_m_s : (..., 3)`` at
    times ``tau_s : (K,)`` from the state (``p0_m``, ``v0_m_s``) (each (3,))."""
    p0 = np.asarray(p0_m, dtype=np.float64)
    v0 = np.asarray(v0_m_s, dtype=np.float64)
    va = np.asarray(va_m_s, dtype=np.float64)[..., None, :]  # (..., 1, 3)
    tau = np.asarray(tau_s, dtype=np.float64)[:, None]  # (K, 1)
    dv = va - v0
    dv_norm = np.linalg.norm(dv, axis=-1, keepdims=True)
    t_ramp = dv_norm / accel_m_s2
    u = np.divide(dv, dv_norm, out=np.zeros_like(dv), where=dv_norm > _TINY_M)
    t_in = np.minimum(tau, t_ramp)  # time spent ramping
    p = p0 + v0 * t_in + 0.5 * accel_m_s2 * u * t_in**2 + va * (tau - t_in)
    v = v0 + accel_m_s2 * u * t_in
    return p, v


def state_at(
    p0_m: Sequence[float],
    v0_m_s: Sequence[float],
    va_m_s: Sequence[float],
    tau_s: float,
    accel_m_s2: float,
) -> tuple[Vec3, Vec3]:
    """Eq. (2) at one time ``tau_s``: position and velocity, as ``rollout`` gives them bit for
    bit (the same operations in the same order), without the arrays (the planner's setpoint:
    two times, every decision)."""
    dv = [va - v for va, v in zip(va_m_s, v0_m_s, strict=True)]
    dv_norm = math.sqrt(dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2])
    t_in = min(tau_s, dv_norm / accel_m_s2)  # time spent ramping
    u = [d / dv_norm for d in dv] if dv_norm > _TINY_M else [0.0, 0.0, 0.0]
    half_a = 0.5 * accel_m_s2
    p = tuple(
        p0 + v0 * t_in + half_a * ui * (t_in * t_in) + va * (tau_s - t_in)
        for p0, v0, ui, va in zip(p0_m, v0_m_s, u, va_m_s, strict=True)
    )
    v = tuple(v0 + accel_m_s2 * ui * t_in for v0, ui in zip(v0_m_s, u, strict=True))
    return (p[0], p[1], p[2]), (v[0], v[1], v[2])


def clip_to_envelope(v_ned_m_s: ArrayLike, cfg: PlannerConfig) -> FloatArray:
    """Clip a velocity ``(3,)`` into the envelope: down speed in [-max_climb, max_descent], then
    |v| <= max_speed (scaling all three components)."""
    v = np.asarray(v_ned_m_s, dtype=np.float64).copy()
    v[2] = min(max(v[2], -cfg.max_climb_m_s), cfg.max_descent_m_s)
    speed = float(np.linalg.norm(v))
    if speed > cfg.max_speed_m_s:
        v *= cfg.max_speed_m_s / speed
    return v
