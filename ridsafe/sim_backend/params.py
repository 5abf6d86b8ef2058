"""Parameters of the simulated octorotor and of its autopilot's cascaded controller.

Two frozen dataclasses, units in the field names, validated at construction (a bad value raises
:class:`~ridsafe.common.errors.FieldValueError`, a ``ValueError`` naming the field):

- :class:`OctorotorParams`: the airframe of the paper's section "Aircraft Model" (mass, inertia,
  arm length; Table "Aircraft Model Parameters") plus its actuator limits and the paper's discrete
  action set (9 thrust values log-spaced in [50, 500] N, 7 torque values uniform in
  [-150, 150] N m per axis).
- :class:`ControllerParams`: gains and limits of the position -> velocity -> attitude -> rate
  cascade, and the two loop rates (physics and controller), which must divide evenly.

Defaults not given by the paper follow ArduCopter's where one exists (``ANGLE_MAX`` 30 deg,
``WPNAV_SPEED_UP`` 2.5 m/s, ``WPNAV_SPEED_DN`` 1.5 m/s, ``PSC_POSXY_P`` 1, ``PSC_VELXY_P`` 2);
the rest are ours, tuned on this model (see ``tests/sim_backend/test_controller.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ridsafe.common.checks import check_numeric_fields_positive
from ridsafe.common.errors import FieldValueError

__all__ = ["ControllerParams", "OctorotorParams"]

# The longest physics step we accept: RK4 on this airframe's rate loop stays accurate below it.
MAX_PHYSICS_STEP_S = 0.005


@dataclass(frozen=True)
class OctorotorParams:
    """The paper's octorotor (eq. 2) and its actuator limits.

    ``thrust_min_n`` > 0 is the idle thrust of spinning rotors: an *armed* vehicle never produces
    less. A disarmed vehicle (motors stopped) produces zero thrust and torque.
    """

    mass_kg: float = 12.66
    ixx_kg_m2: float = 0.2506
    iyy_kg_m2: float = 0.2506
    izz_kg_m2: float = 1.0024
    arm_length_m: float = 0.635
    gravity_m_s2: float = 9.80665
    thrust_min_n: float = 50.0
    thrust_max_n: float = 500.0
    torque_max_nm: float = 150.0
    n_thrust_levels: int = 9
    n_torque_levels: int = 7

    def __post_init__(self) -> None:
        check_numeric_fields_positive(self)
        if self.thrust_min_n >= self.thrust_max_n:
            raise FieldValueError(
                "thrust_min_n",
                f"must be < thrust_max_n={self.thrust_max_n}, got {self.thrust_min_n}",
            )
        weight_n = self.mass_kg * self.gravity_m_s2
        if not self.thrust_min_n < weight_n < self.thrust_max_n:
            raise FieldValueError(
                "mass_kg",
                f"weight {weight_n:.1f} N must lie inside the thrust range "
                f"({self.thrust_min_n}, {self.thrust_max_n}) N to hover and descend",
            )
        for name in ("n_thrust_levels", "n_torque_levels"):
            if getattr(self, name) < 2:
                raise FieldValueError(name, f"must be >= 2, got {getattr(self, name)}")

    @property
    def weight_n(self) -> float:
        """m g, the hover thrust at level attitude (N)."""
        return self.mass_kg * self.gravity_m_s2


@dataclass(frozen=True)
class ControllerParams:
    """Gains and limits of the cascaded controller, and the loop rates.

    Cascade (all loops run at ``controller_hz``; physics at ``physics_hz``), equations in
    :mod:`ridsafe.sim_backend.controller`:

    - position -> velocity: square-root shaper, ``pos_gain_1_s`` near the target and
      ``sqrt(2 a d)`` far away, so the vehicle brakes at ``pos_decel_xy_m_s2`` /
      ``pos_decel_z_m_s2``; the shaper's derivative is fed forward;
    - velocity -> acceleration: PI, ``vel_gain_*_1_s`` and ``vel_int_gain_*_1_s2``; the
      integrator only runs while |error| < ``vel_int_band_m_s`` and nothing saturates, and is
      clamped to ``vel_int_limit_m_s2`` (anti-windup); acceleration limited by the tilt and by
      ``max_accel_up_m_s2`` / ``max_accel_down_m_s2``;
    - acceleration -> attitude and thrust, tilt limited to ``max_tilt_deg``;
    - attitude -> body rates: ``att_gain_*_1_s``, limited to ``max_rp_rate_deg_s`` and
      ``max_yaw_rate_deg_s``;
    - body rates -> torques: ``rate_gain_*_1_s`` times I / l, gyroscopic terms cancelled.

    ``quantise_to_action_set`` snaps every command to the paper's discrete action set with
    sigma-delta error feedback (see :mod:`ridsafe.sim_backend.actuation`).
    """

    pos_gain_1_s: float = 1.0
    pos_decel_xy_m_s2: float = 2.5
    pos_decel_z_m_s2: float = 1.5
    vel_gain_xy_1_s: float = 2.0
    vel_int_gain_xy_1_s2: float = 0.4
    vel_gain_z_1_s: float = 3.0
    vel_int_gain_z_1_s2: float = 1.0
    vel_int_limit_m_s2: float = 2.0
    vel_int_band_m_s: float = 0.5
    max_accel_up_m_s2: float = 5.0
    max_accel_down_m_s2: float = 4.0
    att_gain_rp_1_s: float = 6.0
    att_gain_yaw_1_s: float = 3.0
    rate_gain_rp_1_s: float = 30.0
    rate_gain_yaw_1_s: float = 10.0
    max_speed_m_s: float = 8.0
    max_climb_m_s: float = 2.5
    max_descent_m_s: float = 1.5
    max_tilt_deg: float = 30.0
    max_rp_rate_deg_s: float = 120.0
    max_yaw_rate_deg_s: float = 60.0
    physics_hz: int = 400
    controller_hz: int = 100
    quantise_to_action_set: bool = False

    def __post_init__(self) -> None:
        check_numeric_fields_positive(
            self, may_be_zero=("vel_int_gain_xy_1_s2", "vel_int_gain_z_1_s2")
        )
        for name in ("physics_hz", "controller_hz"):
            if not isinstance(getattr(self, name), int):
                raise FieldValueError(name, f"must be an int, got {getattr(self, name)!r}")
        if self.physics_hz % self.controller_hz != 0:
            raise FieldValueError(
                "physics_hz",
                f"must be a multiple of controller_hz={self.controller_hz}, got {self.physics_hz}",
            )
        if 1.0 / self.physics_hz > MAX_PHYSICS_STEP_S:
            raise FieldValueError(
                "physics_hz",
                f"step 1/{self.physics_hz} s exceeds {MAX_PHYSICS_STEP_S} s; "
                f"need physics_hz >= {math.ceil(1.0 / MAX_PHYSICS_STEP_S)}",
            )
        for name in ("rate_gain_rp_1_s", "rate_gain_yaw_1_s"):
            if getattr(self, name) / self.controller_hz >= 1.0:
                raise FieldValueError(
                    name,
                    f"gain x controller period must be < 1 for a stable discrete rate loop, got "
                    f"{getattr(self, name)} x 1/{self.controller_hz}",
                )
        if not self.max_tilt_deg < 80.0:
            raise FieldValueError(
                "max_tilt_deg", f"must be < 80 (Euler angles), got {self.max_tilt_deg}"
            )
        if self.max_accel_down_m_s2 >= 9.0:
            raise FieldValueError(
                "max_accel_down_m_s2",
                f"must be < 9 m/s^2 (the thrust must stay upward), got {self.max_accel_down_m_s2}",
            )

    @property
    def physics_dt_s(self) -> float:
        """Fixed RK4 step (s)."""
        return 1.0 / self.physics_hz

    @property
    def controller_dt_s(self) -> float:
        """Controller period (s); commands are held constant over it."""
        return 1.0 / self.controller_hz

    @property
    def physics_steps_per_control(self) -> int:
        """How many RK4 steps one controller period spans."""
        return self.physics_hz // self.controller_hz
