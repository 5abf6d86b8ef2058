"""All simulated octorotors of a scenario: their state, targets, arming, and time stepping.

:class:`OctorotorFleet` owns ``state : (N, 12)`` (layout in :mod:`ridsafe.sim_backend.dynamics`)
and advances every vehicle, controller and physics, in one compiled call. Each controller period
(``1 / controller_hz``) it runs, per vehicle::

    cmd = actuate(control(state, target))        # held constant over the period
    repeat physics_hz / controller_hz times:
        state = ground_contact(rk4_step(state, cmd, 1 / physics_hz))

Time is counted in whole controller periods, so ``t_s`` never drifts. A disarmed vehicle applies
zero thrust and torque (motors stopped): in the air it falls, on the ground it rests.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ridsafe.common.jit import jit
from ridsafe.sim_backend.actuation import (
    CMD_THRUST,
    CMD_TORQUE,
    N_COMMAND,
    actuate_into,
    thrust_levels_n,
    torque_levels_nm,
)
from ridsafe.sim_backend.controller import (
    N_MEMORY,
    ControllerConsts,
    TargetMode,
    control_into,
)
from ridsafe.sim_backend.dynamics import (
    IDX_PSI,
    IDX_Z,
    POS_ENU,
    STATE_SIZE,
    VEL_ENU,
    OctorotorConsts,
    ground_contact_into,
    rk4_step_into,
    wrap_angle_rad,
)
from ridsafe.sim_backend.params import ControllerParams, OctorotorParams

__all__ = ["OctorotorFleet"]

FloatArray = NDArray[np.float64]

# advance_to() rounds t_s * controller_hz to a whole period when it is this close to one.
_PERIOD_TOLERANCE = 1e-9
#: Land detector thresholds (see ``OctorotorFleet.on_ground``).
ON_GROUND_HEIGHT_M = 0.05
ON_GROUND_SPEED_M_S = 0.1


@jit
def _advance_kernel(
    state: FloatArray,
    memory: FloatArray,
    sd_error: FloatArray,
    cmd: FloatArray,
    target_pos: FloatArray,
    target_vel: FloatArray,
    target_yaw: FloatArray,
    mode: NDArray[np.int64],
    armed: NDArray[np.bool_],
    n_periods: int,
    substeps: int,
    kc: ControllerConsts,
    ko: OctorotorConsts,
    quantise: bool,
    thrust_levels: FloatArray,
    torque_levels: FloatArray,
) -> None:
    """Advance every vehicle by ``n_periods`` controller periods, all arrays in place."""
    scratch = np.empty((5, STATE_SIZE))
    dt_physics = kc.dt_s / substeps
    for i in range(state.shape[0]):
        s, c = state[i], cmd[i]
        for _ in range(n_periods):
            if armed[i]:
                control_into(
                    s, target_pos[i], target_vel[i], target_yaw[i], mode[i], memory[i], kc, ko, c
                )
            else:
                memory[i, :] = 0.0
            actuate_into(c, armed[i], quantise, sd_error[i], thrust_levels, torque_levels, ko)
            for _ in range(substeps):
                rk4_step_into(s, c[0], c[1], c[2], c[3], dt_physics, ko, scratch)
                ground_contact_into(s)


class OctorotorFleet:
    """N octorotors flown by cascaded controllers, stepped together.

    Vehicles are indexed 0..N-1. They start disarmed, at rest at the origin or at
    ``initial_state : (N, 12)``. The autopilot arms/disarms them, sets targets and reads state.
    """

    def __init__(
        self,
        n_vehicles: int,
        octorotor: OctorotorParams | None = None,
        controller: ControllerParams | None = None,
        initial_state: ArrayLike | None = None,
    ) -> None:
        if n_vehicles < 1:
            raise ValueError(f"n_vehicles must be >= 1, got {n_vehicles}")
        self.octorotor = octorotor if octorotor is not None else OctorotorParams()
        self.controller = controller if controller is not None else ControllerParams()
        n = n_vehicles
        self._state = np.zeros((n, STATE_SIZE))
        if initial_state is not None:
            self._state[:] = self._checked(initial_state, (n, STATE_SIZE), "initial_state")
            psi = self._state[:, IDX_PSI]
            self._state[:, IDX_PSI] = np.pi - np.mod(np.pi - psi, 2.0 * np.pi)
        self._memory = np.zeros((n, N_MEMORY))
        self._sd_error = np.zeros((n, N_COMMAND))
        self._cmd = np.zeros((n, N_COMMAND))
        self._target_pos = self._state[:, POS_ENU].copy()
        self._target_vel = np.zeros((n, 3))
        self._target_yaw = self._state[:, IDX_PSI].copy()
        self._mode = np.full(n, int(TargetMode.POSITION | TargetMode.YAW), dtype=np.int64)
        self._armed = np.zeros(n, dtype=np.bool_)
        self._periods = 0
        self._on_ground: NDArray[np.bool_] | None = None  # of the state now; None: changed
        self._kc = ControllerConsts.from_params(self.controller)
        self._ko = OctorotorConsts.from_params(self.octorotor)
        self._thrust_levels = thrust_levels_n(self.octorotor)
        self._torque_levels = torque_levels_nm(self.octorotor)
        self._advance_periods(0)  # the kernel loaded now, not at the first tick (below)

    @staticmethod
    def _checked(value: ArrayLike, shape: tuple[int, ...], name: str) -> FloatArray:
        arr = np.asarray(value, dtype=np.float64)
        if arr.shape != shape or not all(map(math.isfinite, arr.ravel().tolist())):
            raise ValueError(f"{name} must be finite with shape {shape}, got {arr.shape}")
        return arr

    # -- reading -----------------------------------------------------------------------------

    @property
    def n_vehicles(self) -> int:
        return int(self._state.shape[0])

    @property
    def t_s(self) -> float:
        """Sim time (s): whole controller periods since construction."""
        return self._periods / self.controller.controller_hz

    @property
    def state(self) -> FloatArray:
        """A copy of ``state : (N, 12)``."""
        return self._state.copy()

    def state_of(self, vehicle: int) -> FloatArray:
        """A copy of one vehicle's ``(12,)`` state."""
        row: FloatArray = self._state[vehicle].copy()
        return row

    @property
    def armed(self) -> NDArray[np.bool_]:
        """A copy of the ``(N,)`` armed flags."""
        return self._armed.copy()

    @property
    def on_ground(self) -> NDArray[np.bool_]:
        """``(N,)``: on the ground, as a land detector sees it: within ``ON_GROUND_HEIGHT_M``
        of it and slower than ``ON_GROUND_SPEED_M_S`` (thresholds, as ArduCopter's detector
        has: quantised thrust around m g lifts a waiting vehicle by micrometres now and then).
        Computed once per state: the sim reads it several times a tick."""
        if self._on_ground is None:
            speed = np.linalg.norm(self._state[:, VEL_ENU], axis=1)
            self._on_ground = (self._state[:, IDX_Z] <= ON_GROUND_HEIGHT_M) & (
                speed <= ON_GROUND_SPEED_M_S
            )
        return self._on_ground.copy()

    @property
    def last_command(self) -> tuple[FloatArray, FloatArray]:
        """The applied (thrust_n ``(N,)``, torque_nm ``(N, 3)``) of the last period."""
        return self._cmd[:, CMD_THRUST].copy(), self._cmd[:, CMD_TORQUE].copy()

    # -- commanding --------------------------------------------------------------------------

    def arm(self, vehicle: int) -> None:
        """Start the motors; targets are kept, the controller memory starts from zero."""
        if not self._armed[vehicle]:
            self._memory[vehicle] = 0.0
            self._sd_error[vehicle] = 0.0
        self._armed[vehicle] = True

    def disarm(self, vehicle: int) -> None:
        """Stop the motors (zero thrust and torque from the next period on)."""
        self._armed[vehicle] = False

    def set_state(self, vehicle: int, state: ArrayLike) -> None:
        """Place a vehicle (e.g. at its depot); resets its controller and quantiser memory."""
        s = self._checked(state, (STATE_SIZE,), "state").copy()
        s[IDX_PSI] = wrap_angle_rad(s[IDX_PSI])
        self._state[vehicle] = s
        self._on_ground = None
        self._memory[vehicle] = 0.0
        self._sd_error[vehicle] = 0.0

    def set_target(
        self,
        vehicle: int,
        *,
        position_enu_m: ArrayLike | None = None,
        velocity_enu_m_s: ArrayLike | None = None,
        yaw_rad: float | None = None,
    ) -> None:
        """Set what the vehicle flies to.

        Position only: fly there and hold. Velocity only: track it. Both: track the position
        with the velocity as feed-forward. Neither: brake to a stop where it is.
        ``yaw_rad=None`` holds the heading the vehicle has now.
        """
        mode = TargetMode.YAW
        if position_enu_m is not None:
            self._target_pos[vehicle] = self._checked(position_enu_m, (3,), "position_enu_m")
            mode |= TargetMode.POSITION
        if velocity_enu_m_s is not None:
            self._target_vel[vehicle] = self._checked(velocity_enu_m_s, (3,), "velocity_enu_m_s")
            mode |= TargetMode.VELOCITY
        if yaw_rad is None:
            yaw_rad = float(self._state[vehicle, IDX_PSI])
        elif not math.isfinite(yaw_rad):
            raise ValueError(f"yaw_rad must be finite, got {yaw_rad}")
        self._target_yaw[vehicle] = yaw_rad
        self._mode[vehicle] = int(mode)

    # -- time --------------------------------------------------------------------------------

    def advance(self, n_controller_steps: int = 1) -> None:
        """Run ``n_controller_steps`` controller periods (with their physics) for all vehicles."""
        if n_controller_steps < 0:
            raise ValueError(f"n_controller_steps must be >= 0, got {n_controller_steps}")
        if n_controller_steps == 0:
            return
        self._advance_periods(int(n_controller_steps))
        self._periods += int(n_controller_steps)
        self._on_ground = None

    def _advance_periods(self, n_periods: int) -> None:
        """The compiled step over every vehicle. Called with 0 periods when the fleet is built:
        numba loads a kernel from its cache (or compiles it) at its first call, and a live
        sim's first call would otherwise come after the run's start instant (0.4 s of a slow
        host's wall clock, 2.4 s of sim time at 6x, in which the sim stood still)."""
        _advance_kernel(
            self._state,
            self._memory,
            self._sd_error,
            self._cmd,
            self._target_pos,
            self._target_vel,
            self._target_yaw,
            self._mode,
            self._armed,
            n_periods,
            self.controller.physics_steps_per_control,
            self._kc,
            self._ko,
            self.controller.quantise_to_action_set,
            self._thrust_levels,
            self._torque_levels,
        )

    def advance_to(self, t_s: float) -> None:
        """Advance to the last controller period at or before ``t_s`` (never backwards)."""
        periods = t_s * self.controller.controller_hz
        target = math.floor(periods + _PERIOD_TOLERANCE)
        if target < self._periods:
            raise ValueError(f"cannot go back in time: now {self.t_s} s, asked {t_s} s")
        self.advance(target - self._periods)
