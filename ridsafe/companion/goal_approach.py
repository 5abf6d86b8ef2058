"""Breaking the near-goal deadlock of dense traffic: fly straight at the goal when that is clear.

Within ``approach_radius_m`` (40 m) of its goal the planner flies at the goal itself only when
no hazard is in play or every neighbour stays ``approach_min_separation_m`` (60 m) away from
an aircraft that *hovers* here; otherwise its held-velocity actions cannot bring it within the
10 m arrival radius among traffic. Where deliveries crowd (64 aircraft: a quarter of them ended
the run circling 5-50 m from their goals, neighbours 40-60 m off) that is never the case. The
straight approach itself is what matters, so this module checks it: the aircraft flies from
``p`` at ``speed_m_s`` straight to the goal ``g`` and stops there, every neighbour flies along
its Remote ID velocity, sampled every ``step_s`` over ``horizon_s``::

    own(t) = p + min(speed t, |g - p|) (g - p) / |g - p|
    q_j(t) = q_j + w_j (t - t_j)
    clear  <=>  min over t, j of |own(t) - q_j(t)| >= clear_m

``clear_m`` is above the 50 m NMAC radius. Positions in the local NED frame (m), speeds m/s.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ridsafe.companion.planner_api import Neighbour, Vec3

__all__ = ["straight_approach_clear"]

FloatArray = NDArray[np.float64]


def straight_approach_clear(
    t_s: float,
    p_ned_m: Vec3,
    goal_ned_m: Vec3,
    neighbours: tuple[Neighbour, ...],
    speed_m_s: float,
    clear_m: float,
    horizon_s: float = 10.0,
    step_s: float = 0.5,
) -> bool:
    """True when the straight flight to the goal keeps ``clear_m`` from every neighbour
    (module docstring); ``neighbours`` are the ones to keep clear of."""
    if not neighbours:
        return True
    p = np.asarray(p_ned_m, dtype=np.float64)
    to_goal = np.asarray(goal_ned_m, dtype=np.float64) - p
    length = float(np.linalg.norm(to_goal))
    tau = np.arange(0.0, horizon_s + 1e-9, step_s)  # (K,)
    along = np.minimum(speed_m_s * tau, length)  # (K,)
    unit = to_goal / length if length > 1e-9 else np.zeros(3)
    own = p + along[:, None] * unit  # (K, 3)
    q = np.array([n.p_ned_m for n in neighbours], dtype=np.float64)  # (N, 3)
    w = np.array([n.v_ned_m_s for n in neighbours], dtype=np.float64)
    age = t_s - np.array([n.t_s for n in neighbours], dtype=np.float64)  # (N,)
    q_t = q[None] + w[None] * (age[None, :, None] + tau[:, None, None])  # (K, N, 3)
    gap_m = np.linalg.norm(q_t - own[:, None], axis=-1)  # (K, N)
    return bool(np.min(gap_m) >= clear_m)
