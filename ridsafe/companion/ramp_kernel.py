"""A planner action's rollout, compiled: eq. 2 of :mod:`ridsafe.companion.actions` (from v0
to the action's velocity v_a at constant acceleration, then v_a held), as the planner's
kernel (:mod:`ridsafe.companion.planner_kernel`) evaluates it for every action and sample."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.jit import jit, jit_inline

__all__ = ["ramp_axis", "ramp_position", "ramp_times", "rollout_into", "velocity_ramp"]

FloatArray = NDArray[np.float64]


@jit
def rollout_into(
    p0: FloatArray, v0: FloatArray, va: FloatArray, tau: FloatArray, accel: float, path: FloatArray
) -> None:
    """actions eq. 2: ``path[k]`` = p(tau_k) of the velocity ramp from v0 to va."""
    ramp = velocity_ramp(v0, va, accel)
    for k in range(tau.shape[0]):
        path[k, 0], path[k, 1], path[k, 2] = ramp_position(p0, v0, va, ramp, tau[k])


@jit_inline
def velocity_ramp(
    v0: FloatArray, va: FloatArray, accel: float
) -> tuple[float, float, float, float, float]:
    """(dv, the ramp's duration, half the acceleration per unit dv) of actions eq. 2."""
    dvx, dvy, dvz = va[0] - v0[0], va[1] - v0[1], va[2] - v0[2]
    dv = math.sqrt(dvx * dvx + dvy * dvy + dvz * dvz)
    scale = 0.5 * accel / dv if dv > 1e-9 else 0.0  # half the acceleration vector, per unit dv
    return dvx, dvy, dvz, dv / accel, scale


@jit_inline
def ramp_position(
    p0: FloatArray,
    v0: FloatArray,
    va: FloatArray,
    ramp: tuple[float, float, float, float, float],
    tau: float,
) -> tuple[float, float, float]:
    """p(tau) of actions eq. 2, given its ``velocity_ramp``."""
    dvx, dvy, dvz, t_ramp, scale = ramp
    ti, rest, half_a_t2 = ramp_times(tau, t_ramp, scale)
    return (
        ramp_axis(p0[0], v0[0], va[0], dvx, ti, rest, half_a_t2),
        ramp_axis(p0[1], v0[1], va[1], dvy, ti, rest, half_a_t2),
        ramp_axis(p0[2], v0[2], va[2], dvz, ti, rest, half_a_t2),
    )


@jit_inline
def ramp_times(tau: float, t_ramp: float, scale: float) -> tuple[float, float, float]:
    """(time on the ramp, time after it, half the acceleration x that time squared per unit
    dv) at tau."""
    ti = min(tau, t_ramp)
    return ti, tau - ti, scale * ti * ti


@jit_inline
def ramp_axis(
    p0: float, v0: float, va: float, dv: float, ti: float, rest: float, half_a_t2: float
) -> float:
    """One coordinate of p(tau) (actions eq. 2): ramp from v0 by dv, then va."""
    return p0 + v0 * ti + half_a_t2 * dv + va * rest
