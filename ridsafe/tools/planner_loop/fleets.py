"""Aircraft models of the planner-only closed loop, seen in NED (``FLEETS`` by name).

- :class:`KinematicFleet`: the autopilot's position + velocity law
  (``ridsafe.sim_backend.controller`` step 1, square-root shaper with the velocity
  feed-forward) with its speed, climb and descent limits, then a velocity loop with gain k_v
  and the tilt / vertical acceleration limits.
- :class:`SixDofFleet`: the sim's 6-DoF octorotors with the real cascade.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.frames import ned_to_enu
from ridsafe.companion.planner_config import GRAVITY_M_S2
from ridsafe.sim_backend.params import ControllerParams

__all__ = ["FLEETS", "Fleet", "KinematicFleet", "SixDofFleet"]

FloatArray = NDArray[np.float64]


class Fleet(Protocol):
    p: FloatArray  # (N, 3) NED
    v: FloatArray  # (N, 3) NED

    def set_target(self, i: int, p_ned_m: FloatArray, v_ned_m_s: FloatArray) -> None: ...

    def place(self, i: int, p_ned_m: FloatArray) -> None: ...

    def step(self, dt_s: float) -> None: ...


def _shaped(d: FloatArray, gain: float, decel: float) -> FloatArray:
    """The autopilot's square-root shaper (``controller.shaped_speed``), vectorised."""
    linear = decel / gain**2
    speed: FloatArray = np.where(
        d <= linear, gain * d, np.sqrt(2.0 * decel * np.maximum(d - 0.5 * linear, 0.0))
    )
    return speed


class KinematicFleet:
    """Point masses flown by the autopilot's position + velocity law and limits (NED)."""

    def __init__(self, p_ned_m: FloatArray, ctrl: ControllerParams | None = None) -> None:
        self.ctrl = ctrl if ctrl is not None else ControllerParams()
        self.p = p_ned_m.astype(np.float64).copy()
        self.v = np.zeros_like(self.p)
        self.p_target = self.p.copy()
        self.v_target = np.zeros_like(self.p)

    def set_target(self, i: int, p_ned_m: FloatArray, v_ned_m_s: FloatArray) -> None:
        self.p_target[i], self.v_target[i] = p_ned_m, v_ned_m_s

    def place(self, i: int, p_ned_m: FloatArray) -> None:
        self.p[i] = self.p_target[i] = p_ned_m
        self.v[i] = self.v_target[i] = 0.0

    def step(self, dt_s: float) -> None:
        c = self.ctrl
        e = self.p_target - self.p
        d_xy = np.hypot(e[:, 0], e[:, 1])
        s_xy = _shaped(d_xy, c.pos_gain_1_s, c.pos_decel_xy_m_s2)
        unit = np.divide(
            e[:, :2], d_xy[:, None], out=np.zeros((len(e), 2)), where=d_xy[:, None] > 1e-9
        )
        v_cmd = self.v_target.copy()
        v_cmd[:, :2] += s_xy[:, None] * unit
        v_cmd[:, 2] += np.sign(e[:, 2]) * _shaped(
            np.abs(e[:, 2]), c.pos_gain_1_s, c.pos_decel_z_m_s2
        )
        sxy = np.hypot(v_cmd[:, 0], v_cmd[:, 1])
        v_cmd[:, :2] *= np.minimum(1.0, c.max_speed_m_s / np.maximum(sxy, 1e-9))[:, None]
        v_cmd[:, 2] = np.clip(v_cmd[:, 2], -c.max_climb_m_s, c.max_descent_m_s)
        a = np.empty_like(self.v)
        a[:, :2] = c.vel_gain_xy_1_s * (v_cmd[:, :2] - self.v[:, :2])
        a_max = GRAVITY_M_S2 * math.tan(math.radians(c.max_tilt_deg))
        axy = np.hypot(a[:, 0], a[:, 1])
        a[:, :2] *= np.minimum(1.0, a_max / np.maximum(axy, 1e-9))[:, None]
        a[:, 2] = np.clip(
            c.vel_gain_z_1_s * (v_cmd[:, 2] - self.v[:, 2]),
            -c.max_accel_up_m_s2,
            c.max_accel_down_m_s2,
        )
        self.v += a * dt_s
        self.p += self.v * dt_s


class SixDofFleet:
    """The sim's octorotors (eq. 2 dynamics, cascaded controller), seen in NED."""

    def __init__(self, p_ned_m: FloatArray, ctrl: ControllerParams | None = None) -> None:
        from ridsafe.sim_backend.dynamics import POS_ENU, STATE_SIZE  # noqa: PLC0415
        from ridsafe.sim_backend.vehicles import OctorotorFleet  # noqa: PLC0415

        n = p_ned_m.shape[0]
        state = np.zeros((n, STATE_SIZE))
        state[:, POS_ENU] = ned_to_enu(p_ned_m)
        self._fleet = OctorotorFleet(n, controller=ctrl, initial_state=state)
        self._pos, self._n_state = POS_ENU, STATE_SIZE
        for i in range(n):
            self._fleet.arm(i)
            self._fleet.set_target(i, position_enu_m=state[i, POS_ENU])
        self._fleet.advance(1)  # compile outside the loop
        self.p, self.v = p_ned_m.copy(), np.zeros_like(p_ned_m)
        self._read()

    def _read(self) -> None:
        from ridsafe.sim_backend.dynamics import VEL_ENU  # noqa: PLC0415

        s = self._fleet.state
        self.p, self.v = ned_to_enu(s[:, self._pos]), ned_to_enu(s[:, VEL_ENU])

    def set_target(self, i: int, p_ned_m: FloatArray, v_ned_m_s: FloatArray) -> None:
        self._fleet.set_target(
            i, position_enu_m=ned_to_enu(p_ned_m), velocity_enu_m_s=ned_to_enu(v_ned_m_s)
        )

    def place(self, i: int, p_ned_m: FloatArray) -> None:
        state = np.zeros(self._n_state)
        state[self._pos] = ned_to_enu(p_ned_m)
        self._fleet.set_state(i, state)
        self._fleet.set_target(i, position_enu_m=state[self._pos])
        self._read()

    def step(self, dt_s: float) -> None:
        self._fleet.advance(round(dt_s * self._fleet.controller.controller_hz))
        self._read()


FLEETS: dict[str, Callable[[FloatArray], Fleet]] = {
    "kinematic": KinematicFleet,
    "6dof": SixDofFleet,
}
