"""WPNAV_SPEED: the horizontal speed of the sim autopilot's position-only targets.

ArduCopter flies GUIDED position targets (SET_POSITION_TARGET with a position only,
DO_REPOSITION, guided MISSION_ITEM) and AUTO waypoints at no more than ``WPNAV_SPEED``
(cm/s). The sim's controller flies a position target at up to its own ``max_speed_m_s``, so
:class:`WaypointNav` sits between the autopilot and its vehicle and, when ``WPNAV_SPEED`` is
below that cap, flies a position-only target along the line from where the vehicle was when it
got the target: the target handed to the controller is the vehicle's own projection on that
line (no along-track error; the cross-track error pulls it back onto the line) with
``WPNAV_SPEED`` along it as feed-forward, until the vehicle is as close as the controller's
square-root shaper would fly at ``WPNAV_SPEED``; from there the target itself, so the vehicle
brakes onto it as before. Targets with a velocity, and every target while ``WPNAV_SPEED`` is at
or above the controller's cap (ArduCopter's default 1000 cm/s against the sim's 8 m/s), go
through unchanged.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ridsafe.sim_backend.param_table import ParamStore
from ridsafe.sim_backend.params import ControllerParams

if TYPE_CHECKING:
    from ridsafe.sim_backend.autopilot import Actuators, VehicleSample

__all__ = ["WaypointNav", "shaper_distance_m"]

FloatArray = NDArray[np.float64]


def shaper_distance_m(speed_m_s: float, controller: ControllerParams) -> float:
    """The distance at which the controller's horizontal square-root shaper asks for
    ``speed_m_s`` (the inverse of ``controller.shaped_speed``)."""
    gain, decel = controller.pos_gain_1_s, controller.pos_decel_xy_m_s2
    linear_dist = decel / (gain * gain)
    if speed_m_s <= gain * linear_dist:
        return speed_m_s / gain
    return speed_m_s * speed_m_s / (2.0 * decel) + 0.5 * linear_dist


class WaypointNav:
    """The autopilot's ``Actuators`` with WPNAV_SPEED applied to position-only targets."""

    def __init__(self, inner: Actuators, params: ParamStore, controller: ControllerParams):
        self.inner = inner
        self.params = params
        self.controller = controller
        self._vehicle = 0
        self._destination: FloatArray | None = None
        self._start_xy: FloatArray | None = None
        self._yaw_rad: float | None = None

    def limit_m_s(self) -> float | None:
        """The horizontal speed limit now, or None when the controller's cap is lower."""
        wpnav_m_s = self.params.get("WPNAV_SPEED") / 100.0
        return wpnav_m_s if wpnav_m_s < self.controller.max_speed_m_s else None

    def arm(self, vehicle: int) -> None:
        self.inner.arm(vehicle)

    def disarm(self, vehicle: int) -> None:
        self._destination = None
        self.inner.disarm(vehicle)

    def set_target(
        self,
        vehicle: int,
        *,
        position_enu_m: ArrayLike | None = None,
        velocity_enu_m_s: ArrayLike | None = None,
        yaw_rad: float | None = None,
    ) -> None:
        if position_enu_m is None or velocity_enu_m_s is not None or self.limit_m_s() is None:
            self._destination = None
            self.inner.set_target(vehicle, position_enu_m=position_enu_m,
                                  velocity_enu_m_s=velocity_enu_m_s, yaw_rad=yaw_rad)  # fmt: skip
            return
        destination = np.array(position_enu_m, dtype=np.float64)
        if self._destination is None or not np.allclose(destination, self._destination):
            self._start_xy = None  # a new target: its line starts where the vehicle is
        self._vehicle, self._destination, self._yaw_rad = vehicle, destination, yaw_rad

    def update(self, sample: VehicleSample) -> None:
        """Hand the vehicle this tick's target for the position-only target in force."""
        if self._destination is None:
            return
        limit = self.limit_m_s()
        p_xy = np.array(sample.p_enu_m[:2], dtype=np.float64)
        if self._start_xy is None:
            self._start_xy = p_xy
        line = self._destination[:2] - self._start_xy
        length = float(np.hypot(*line))
        remaining = float(np.hypot(*(self._destination[:2] - p_xy)))
        if limit is None or length < 1e-6 or remaining <= shaper_distance_m(limit, self.controller):
            self.inner.set_target(self._vehicle, position_enu_m=self._destination,
                                  yaw_rad=self._yaw_rad)  # fmt: skip
            self._destination = None
            return
        unit = line / length
        along_m = min(max(float(np.dot(p_xy - self._start_xy, unit)), 0.0), length)
        on_line = self._start_xy + unit * along_m
        self.inner.set_target(
            self._vehicle,
            position_enu_m=np.array([on_line[0], on_line[1], self._destination[2]]),
            velocity_enu_m_s=np.array([unit[0] * limit, unit[1] * limit, 0.0]),
            yaw_rad=self._yaw_rad,
        )
