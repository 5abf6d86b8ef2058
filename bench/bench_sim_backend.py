"""Benchmark (not a test): how much faster than real time the sim backend integrates 17 vehicles.

Runs physics (RK4 at ``physics_hz``) and the cascaded controllers (``controller_hz``) of 17
octorotors flying position steps, for 120 s of sim time, and prints the real-time factor: with
one compiled call per second of sim time (continuous and quantised commands), and with one call
per controller period (what a lockstep runner does, paying numba's dispatch cost each time). For
scale it also times the plain-numpy RK4 reference (physics only, no controller) over a few
hundred steps and extrapolates.

Run: ``.venv/bin/python bench/bench_sim_backend.py``
"""

from __future__ import annotations

import time

import numpy as np

from ridsafe.sim_backend.dynamics import IDX_Z, POS_ENU, STATE_SIZE, rk4_step_reference
from ridsafe.sim_backend.params import ControllerParams, OctorotorParams
from ridsafe.sim_backend.vehicles import OctorotorFleet

N_VEHICLES = 17
SIM_S = 120.0
NUMPY_STEPS = 400


def _fleet(quantise: bool) -> OctorotorFleet:
    rng = np.random.default_rng(7)
    start = np.zeros((N_VEHICLES, STATE_SIZE))
    start[:, POS_ENU] = rng.uniform([-500, -500, 30], [500, 500, 80], size=(N_VEHICLES, 3))
    fleet = OctorotorFleet(
        N_VEHICLES,
        controller=ControllerParams(quantise_to_action_set=quantise),
        initial_state=start,
    )
    goals = rng.uniform([-500, -500, 30], [500, 500, 80], size=(N_VEHICLES, 3))
    for i in range(N_VEHICLES):
        fleet.arm(i)
        fleet.set_target(i, position_enu_m=goals[i], yaw_rad=float(rng.uniform(-3, 3)))
    return fleet


def bench_compiled(quantise: bool, periods_per_call: int) -> tuple[float, float]:
    """(wall seconds, real-time factor) for SIM_S of sim time in calls of ``periods_per_call``."""
    fleet = _fleet(quantise)
    fleet.advance(1)  # compile or load the cache outside the timing
    n_calls = round(SIM_S * fleet.controller.controller_hz) // periods_per_call
    t0 = time.perf_counter()
    for _ in range(n_calls):
        fleet.advance(periods_per_call)
    wall = time.perf_counter() - t0
    return wall, SIM_S / wall


def bench_numpy_physics(params: OctorotorParams, dt_s: float) -> float:
    """Real-time factor of the numpy RK4 reference, physics only, 17 vehicles."""
    state = np.zeros((N_VEHICLES, STATE_SIZE))
    state[:, IDX_Z] = 50.0
    thrust = np.full(N_VEHICLES, params.weight_n)
    torque = np.zeros((N_VEHICLES, 3))
    t0 = time.perf_counter()
    for _ in range(NUMPY_STEPS):
        state = rk4_step_reference(state, thrust, torque, dt_s, params)
    wall = time.perf_counter() - t0
    return NUMPY_STEPS * dt_s / wall


def main() -> None:
    ctrl = ControllerParams()
    print(
        f"{N_VEHICLES} vehicles, {SIM_S:.0f} s sim, physics {ctrl.physics_hz} Hz RK4, "
        f"controller {ctrl.controller_hz} Hz"
    )
    steps = SIM_S * ctrl.physics_hz
    cases = (
        ("numba, 1 call per sim second", False, ctrl.controller_hz),
        ("numba, quantised, 1 call per s", True, ctrl.controller_hz),
        ("numba, 1 call per ctrl period", False, 1),
    )
    for label, quantise, periods_per_call in cases:
        wall, factor = bench_compiled(quantise, periods_per_call)
        print(
            f"  {label:34s}: {wall * 1e3:7.1f} ms wall, {factor:6.0f}x real time, "
            f"{wall / steps * 1e6:5.2f} us per physics step (17 vehicles + controllers)"
        )
    np_factor = bench_numpy_physics(OctorotorParams(), ctrl.physics_dt_s)
    print(f"  {'numpy RK4 reference, physics only':34s}: {np_factor:6.1f}x real time")


if __name__ == "__main__":
    main()
