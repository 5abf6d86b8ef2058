"""From the controller's wish to what the rotors deliver: saturation and the paper's action set.

Command per vehicle: ``cmd : (4,)`` = (T, tau_phi, tau_theta, tau_psi) in N and N m.

Saturation (armed)::

    T     <- clip(T, T_min, T_max)              T_min = 50 N, T_max = 500 N
    tau_i <- clip(tau_i, -tau_max, tau_max)     tau_max = 150 N m

Disarmed means the motors are stopped: T = 0 and tau = 0, below the 50 N idle minimum.

The paper's discrete action set (section "Aircraft Model")::

    thrust levels  T_k   = T_min (T_max / T_min)^(k / 8),   k = 0..8    (9, log-spaced)
    torque levels  tau_j = -tau_max + j tau_max / 3,         j = 0..6    (7, uniform)

Nearest-level quantisation alone cannot hover: m g = 124.2 N lies between 118.6 N and 158.1 N.
We therefore quantise with error feedback (first-order sigma-delta) per channel and vehicle::

    u_k = nearest_level(v_k + e_k)
    e_{k+1} = (v_k + e_k) - u_k

so the running mean of the applied commands equals the mean of the wished ones, with
|e| <= half the widest gap between neighbouring levels (v_k is saturated first, so it lies inside
the level range). The error is reset when a vehicle is disarmed.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.jit import jit
from ridsafe.sim_backend.dynamics import OctorotorConsts
from ridsafe.sim_backend.params import OctorotorParams

__all__ = [
    "CMD_THRUST",
    "CMD_TORQUE",
    "N_COMMAND",
    "actuate_into",
    "quantise_nearest",
    "quantise_sigma_delta",
    "saturate",
    "thrust_levels_n",
    "torque_levels_nm",
]

FloatArray = NDArray[np.float64]

# cmd layout: thrust, then the three body torques.
N_COMMAND = 4
CMD_THRUST = 0
CMD_TORQUE = slice(1, 4)


def thrust_levels_n(params: OctorotorParams) -> FloatArray:
    """The paper's thrust values: ``n_thrust_levels`` log-spaced in [T_min, T_max] (N)."""
    return np.geomspace(params.thrust_min_n, params.thrust_max_n, params.n_thrust_levels)


def torque_levels_nm(params: OctorotorParams) -> FloatArray:
    """The paper's torque values per axis: ``n_torque_levels`` uniform in +/-tau_max (N m)."""
    return np.linspace(-params.torque_max_nm, params.torque_max_nm, params.n_torque_levels)


@jit
def _nearest_level(value: float, levels: FloatArray) -> float:
    """The element of sorted ``levels`` closest to ``value`` (ties go to the lower one)."""
    j = np.searchsorted(levels, value)
    if j == 0:
        return float(levels[0])
    if j == levels.shape[0]:
        return float(levels[-1])
    lo, hi = levels[j - 1], levels[j]
    return float(hi) if hi - value < value - lo else float(lo)


@jit
def quantise_sigma_delta(value: float, error: float, levels: FloatArray) -> tuple[float, float]:
    """One sigma-delta step: returns (applied level, carried error)."""
    wished = value + error
    applied = _nearest_level(wished, levels)
    return applied, wished - applied


@jit
def actuate_into(
    cmd: FloatArray,
    armed: bool,
    quantise: bool,
    sd_error: FloatArray,
    thrust_levels: FloatArray,
    torque_levels: FloatArray,
    k: OctorotorConsts,
) -> None:
    """Turn one vehicle's wished ``cmd : (4,)`` into the applied one, in place.

    ``sd_error : (4,)`` is that vehicle's sigma-delta memory, updated when ``quantise``.
    """
    if not armed:
        cmd[:] = 0.0
        sd_error[:] = 0.0
        return
    cmd[CMD_THRUST] = min(max(cmd[CMD_THRUST], k.thrust_min_n), k.thrust_max_n)
    for j in range(CMD_THRUST + 1, N_COMMAND):
        cmd[j] = min(max(cmd[j], -k.torque_max_nm), k.torque_max_nm)
    if not quantise:
        return
    cmd[CMD_THRUST], sd_error[CMD_THRUST] = quantise_sigma_delta(
        cmd[CMD_THRUST], sd_error[CMD_THRUST], thrust_levels
    )
    for j in range(CMD_THRUST + 1, N_COMMAND):
        cmd[j], sd_error[j] = quantise_sigma_delta(cmd[j], sd_error[j], torque_levels)


def saturate(
    thrust_n: FloatArray, torque_nm: FloatArray, params: OctorotorParams
) -> tuple[FloatArray, FloatArray]:
    """Clip an armed fleet's ``thrust_n : (N,)`` and ``torque_nm : (N, 3)`` to the limits."""
    thrust = np.clip(thrust_n, params.thrust_min_n, params.thrust_max_n)
    torque = np.clip(torque_nm, -params.torque_max_nm, params.torque_max_nm)
    return thrust, torque


def quantise_nearest(values: FloatArray, levels: FloatArray) -> FloatArray:
    """Nearest-level quantisation (no error feedback) of any array, for analysis and tests."""
    levels = np.sort(np.asarray(levels, dtype=np.float64))
    j = np.clip(np.searchsorted(levels, values), 1, levels.size - 1)
    lo, hi = levels[j - 1], levels[j]
    result: FloatArray = np.where(hi - values < values - lo, hi, lo)
    return result
