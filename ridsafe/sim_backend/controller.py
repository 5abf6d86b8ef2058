"""The autopilot's cascaded controller: position -> velocity -> attitude -> body rates -> torques.

Frames and state layout as in :mod:`ridsafe.sim_backend.dynamics` (ENU world, FLU body, ZYX Euler
angles). All loops run once per controller period dt; the output (T, tau) is held over it.

Targets per vehicle: ``p* : (3,)`` ENU m, ``v* : (3,)`` ENU m/s, ``psi* `` rad and a bitmask
``mode`` of :class:`TargetMode` saying which are valid.

1. Position -> velocity (square-root shaper, as ArduCopter's ``sqrt_controller``), with the
   shaped command's time derivative as acceleration feed-forward::

       e = p* - p;   d = |e_xy| (horizontal) or |e_z| (vertical)
       speed(d) = k_p d                              if d <= a / k_p^2
                = sqrt(2 a (d - a / (2 k_p^2)))      otherwise
       v_cmd = [v* if VELOCITY] + [speed(d) e / d if POSITION]
       a_ff  = d/dt [speed(d) e / d]  with  de/dt = [v* if VELOCITY] - v
       |v_cmd,xy| <= v_max,   -v_down <= v_cmd,z <= v_up   (a_ff = 0 on a clipped part)

   Far from the target the vehicle brakes at a constant deceleration a along the square-root
   profile and a_ff keeps it on the profile (no lag, hence no overshoot); near it the loop is a
   linear PD (k_v k_p e - (k_v + k_p) v). With neither POSITION nor VELOCITY it brakes to a stop.

2. Velocity -> acceleration (PI with anti-windup)::

       a_u = k_v (v_cmd - v) + a_ff + i
       |a_xy| <= g tan(tilt_max),   -a_down <= a_z <= a_up
       i += k_i (v_cmd - v) dt   only on axes whose output and velocity command are not clipped
                                 and whose error is within the band |v_cmd - v| < b;
       |i| <= i_max;  i = 0 while on the ground (z <= 0).

3. Acceleration -> attitude and thrust. Specific force f = a + g e_z, horizontal part scaled to
   |f_xy| <= f_z tan(tilt_max). With h = Rz(-psi*) f and R[:, 2] = f / |f| (ZYX angles)::

       phi*   = asin(-h_y / |f|)
       theta* = atan2(h_x, h_z)
       T      = m f_z / max(c(phi) c(theta), 1/2)     (vertical priority, as ArduCopter's
                                                        angle boost: T c(phi) c(theta) = m f_z)

4. Attitude -> body rates: Euler-rate command from the angle errors (yaw error wrapped to
   (-pi, pi]; no YAW bit means psi_dot* = 0), mapped to body rates by the inverse of eq. (2)'s
   kinematics::

       phi_dot* = k_a (phi* - phi),  theta_dot* = k_a (theta* - theta),
       psi_dot* = clip(k_ay wrap(psi* - psi), +/-r_max)
       p* = phi_dot* - psi_dot* s(theta)
       q* = theta_dot* c(phi) + psi_dot* s(phi) c(theta)
       r* = -theta_dot* s(phi) + psi_dot* c(phi) c(theta)

   p*, q* limited to +/-rate_max_rp, r* to +/-r_max.

5. Body rates -> torques: wished angular acceleration alpha = k_r (omega* - omega); eq. (2)
   inverted, gyroscopic terms cancelled::

       tau_phi   = (Ixx alpha_p - (Iyy - Izz) q r) / l
       tau_theta = (Iyy alpha_q - (Izz - Ixx) p r) / l
       tau_psi   = (Izz alpha_r - (Ixx - Iyy) p q) / l

Saturation and the optional quantisation to the paper's action set are in
:mod:`ridsafe.sim_backend.actuation`.
"""

from __future__ import annotations

import enum
import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.jit import jit
from ridsafe.sim_backend.dynamics import (
    IDX_P,
    IDX_PHI,
    IDX_PSI,
    IDX_Q,
    IDX_R,
    IDX_THETA,
    IDX_VX,
    IDX_VY,
    IDX_VZ,
    IDX_X,
    IDX_Y,
    IDX_Z,
    OctorotorConsts,
    wrap_angle_rad,
)
from ridsafe.sim_backend.params import ControllerParams

__all__ = [
    "MODE_POSITION",
    "MODE_VELOCITY",
    "MODE_YAW",
    "N_MEMORY",
    "ControllerConsts",
    "TargetMode",
    "control_into",
    "shaped_speed",
]

FloatArray = NDArray[np.float64]


class TargetMode(enum.IntFlag):
    """Which parts of a vehicle's target are valid (bitmask, stored as int64 per vehicle)."""

    NONE = 0
    POSITION = 1
    VELOCITY = 2
    YAW = 4


# Plain ints for the numba kernels (same values as TargetMode).
MODE_POSITION = int(TargetMode.POSITION)
MODE_VELOCITY = int(TargetMode.VELOCITY)
MODE_YAW = int(TargetMode.YAW)

# Thrust boost for tilt, T = m f_z / cos(tilt), stops growing beyond 60 deg of tilt.
_MIN_COS_TILT = 0.5

# Per-vehicle controller memory: the velocity-loop integrator (ENU, m/s^2).
N_MEMORY = 3


class ControllerConsts(NamedTuple):
    """:class:`ControllerParams` as the kernels take it (SI units, radians, dt in s)."""

    pos_gain: float
    pos_decel_xy: float
    pos_decel_z: float
    vel_gain_xy: float
    vel_int_gain_xy: float
    vel_gain_z: float
    vel_int_gain_z: float
    vel_int_limit: float
    vel_int_band: float
    max_accel_up: float
    max_accel_down: float
    att_gain_rp: float
    att_gain_yaw: float
    rate_gain_rp: float
    rate_gain_yaw: float
    max_speed: float
    max_climb: float
    max_descent: float
    tan_max_tilt: float
    max_rp_rate: float
    max_yaw_rate: float
    dt_s: float

    @classmethod
    def from_params(cls, c: ControllerParams) -> ControllerConsts:
        return cls(
            c.pos_gain_1_s,
            c.pos_decel_xy_m_s2,
            c.pos_decel_z_m_s2,
            c.vel_gain_xy_1_s,
            c.vel_int_gain_xy_1_s2,
            c.vel_gain_z_1_s,
            c.vel_int_gain_z_1_s2,
            c.vel_int_limit_m_s2,
            c.vel_int_band_m_s,
            c.max_accel_up_m_s2,
            c.max_accel_down_m_s2,
            c.att_gain_rp_1_s,
            c.att_gain_yaw_1_s,
            c.rate_gain_rp_1_s,
            c.rate_gain_yaw_1_s,
            c.max_speed_m_s,
            c.max_climb_m_s,
            c.max_descent_m_s,
            math.tan(math.radians(c.max_tilt_deg)),
            math.radians(c.max_rp_rate_deg_s),
            math.radians(c.max_yaw_rate_deg_s),
            c.controller_dt_s,
        )


@jit
def _clip(x: float, lo: float, hi: float) -> float:
    return min(max(x, lo), hi)


@jit
def shaped_speed(d: float, gain: float, decel: float) -> tuple[float, float]:
    """Square-root shaper at distance ``d >= 0``: (speed, d speed / d d) (step 1)."""
    linear_dist = decel / (gain * gain)
    if d <= linear_dist:
        return gain * d, gain
    speed = math.sqrt(2.0 * decel * (d - 0.5 * linear_dist))
    return speed, decel / speed


@jit
def _shape_xy(
    ex: float, ey: float, dex: float, dey: float, kc: ControllerConsts
) -> tuple[float, float, float, float]:
    """Horizontal shaped velocity ``speed(d) e / d`` and its time derivative.

    ``(ex, ey)`` is the position error and ``(dex, dey)`` its rate (v* - v, or -v).
    """
    d = math.hypot(ex, ey)
    if d < 1e-9:
        return 0.0, 0.0, kc.pos_gain * dex, kc.pos_gain * dey
    speed, slope = shaped_speed(d, kc.pos_gain, kc.pos_decel_xy)
    ux, uy = ex / d, ey / d
    d_dot = ux * dex + uy * dey
    ratio = speed / d
    ax = slope * d_dot * ux + ratio * (dex - ux * d_dot)
    ay = slope * d_dot * uy + ratio * (dey - uy * d_dot)
    return speed * ux, speed * uy, ax, ay


@jit
def _velocity_command(
    s: FloatArray, p_target: FloatArray, v_target: FloatArray, mode: int, kc: ControllerConsts
) -> tuple[float, float, float, float, float, float, bool, bool]:
    """Wished velocity, its feed-forward acceleration (step 1) and which parts hit a limit."""
    vx, vy, vz, ax, ay, az = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    dex, dey, dez = -s[IDX_VX], -s[IDX_VY], -s[IDX_VZ]
    if mode & MODE_VELOCITY:
        vx, vy, vz = v_target[0], v_target[1], v_target[2]
        dex, dey, dez = dex + vx, dey + vy, dez + vz
    if mode & MODE_POSITION:
        ex, ey, ez = p_target[0] - s[IDX_X], p_target[1] - s[IDX_Y], p_target[2] - s[IDX_Z]
        sx, sy, ax, ay = _shape_xy(ex, ey, dex, dey, kc)
        vx, vy = vx + sx, vy + sy
        speed_z, slope_z = shaped_speed(abs(ez), kc.pos_gain, kc.pos_decel_z)
        vz += math.copysign(speed_z, ez)
        az = slope_z * dez
    sxy = math.hypot(vx, vy)
    xy_limited = sxy >= kc.max_speed
    if xy_limited:
        vx, vy, ax, ay = vx * kc.max_speed / sxy, vy * kc.max_speed / sxy, 0.0, 0.0
    vz_clipped = _clip(vz, -kc.max_descent, kc.max_climb)
    z_limited = vz_clipped != vz
    if z_limited:
        az = 0.0
    return vx, vy, vz_clipped, ax, ay, az, xy_limited, z_limited


@jit
def _integrate(
    integ: FloatArray,
    ex: float,
    ey: float,
    ez: float,
    hold_xy: bool,
    hold_z: bool,
    kc: ControllerConsts,
) -> None:
    """Velocity-loop integrator with anti-windup (step 2)."""
    band = kc.vel_int_band
    if not hold_xy and math.hypot(ex, ey) < band:
        integ[0] += kc.vel_int_gain_xy * ex * kc.dt_s
        integ[1] += kc.vel_int_gain_xy * ey * kc.dt_s
        ixy = math.hypot(integ[0], integ[1])
        if ixy > kc.vel_int_limit:
            integ[0] *= kc.vel_int_limit / ixy
            integ[1] *= kc.vel_int_limit / ixy
    if not hold_z and abs(ez) < band:
        integ[2] = _clip(
            integ[2] + kc.vel_int_gain_z * ez * kc.dt_s, -kc.vel_int_limit, kc.vel_int_limit
        )


@jit
def _accel_command(
    s: FloatArray,
    v_cmd: tuple[float, float, float],
    a_ff: tuple[float, float, float],
    limited: tuple[bool, bool],
    integ: FloatArray,
    kc: ControllerConsts,
    gravity: float,
) -> tuple[float, float, float]:
    """Wished acceleration (step 2); updates the integrator ``integ : (3,)``."""
    ex, ey, ez = v_cmd[0] - s[IDX_VX], v_cmd[1] - s[IDX_VY], v_cmd[2] - s[IDX_VZ]
    ax = kc.vel_gain_xy * ex + a_ff[0] + integ[0]
    ay = kc.vel_gain_xy * ey + a_ff[1] + integ[1]
    az_u = kc.vel_gain_z * ez + a_ff[2] + integ[2]
    a_xy_max = gravity * kc.tan_max_tilt
    axy = math.hypot(ax, ay)
    sat_xy = axy > a_xy_max
    if sat_xy:
        ax *= a_xy_max / axy
        ay *= a_xy_max / axy
    az = _clip(az_u, -kc.max_accel_down, kc.max_accel_up)
    if s[IDX_Z] <= 0.0:
        integ[:] = 0.0
    else:
        _integrate(integ, ex, ey, ez, sat_xy or limited[0], az != az_u or limited[1], kc)
    return ax, ay, az


@jit
def _attitude_and_thrust(
    s: FloatArray,
    ax: float,
    ay: float,
    az: float,
    yaw_target: float,
    kc: ControllerConsts,
    ko: OctorotorConsts,
) -> tuple[float, float, float]:
    """Wished (phi, theta) for heading ``yaw_target`` and the thrust (step 3)."""
    fx, fy, fz = ax, ay, az + ko.gravity_m_s2
    fxy = math.hypot(fx, fy)
    fxy_max = fz * kc.tan_max_tilt
    if fxy > fxy_max:
        fx *= fxy_max / fxy
        fy *= fxy_max / fxy
    cy, sy = math.cos(yaw_target), math.sin(yaw_target)
    hx = cy * fx + sy * fy
    hy = -sy * fx + cy * fy
    fnorm = math.sqrt(fx * fx + fy * fy + fz * fz)
    phi_d = math.asin(_clip(-hy / fnorm, -1.0, 1.0))
    theta_d = math.atan2(hx, fz)
    cos_tilt = math.cos(s[IDX_PHI]) * math.cos(s[IDX_THETA])
    thrust = ko.mass_kg * fz / max(cos_tilt, _MIN_COS_TILT)
    return phi_d, theta_d, thrust


@jit
def _body_rate_command(
    s: FloatArray,
    phi_d: float,
    theta_d: float,
    yaw_target: float,
    has_yaw: bool,
    kc: ControllerConsts,
) -> tuple[float, float, float]:
    """Wished body rates (p, q, r) from the attitude errors (step 4)."""
    phi_dot = kc.att_gain_rp * (phi_d - s[IDX_PHI])
    theta_dot = kc.att_gain_rp * (theta_d - s[IDX_THETA])
    psi_dot = 0.0
    if has_yaw:
        psi_dot = _clip(
            kc.att_gain_yaw * wrap_angle_rad(yaw_target - s[IDX_PSI]),
            -kc.max_yaw_rate,
            kc.max_yaw_rate,
        )
    sphi, cphi = math.sin(s[IDX_PHI]), math.cos(s[IDX_PHI])
    sth, cth = math.sin(s[IDX_THETA]), math.cos(s[IDX_THETA])
    p = phi_dot - psi_dot * sth
    q = theta_dot * cphi + psi_dot * sphi * cth
    r = -theta_dot * sphi + psi_dot * cphi * cth
    return (
        _clip(p, -kc.max_rp_rate, kc.max_rp_rate),
        _clip(q, -kc.max_rp_rate, kc.max_rp_rate),
        _clip(r, -kc.max_yaw_rate, kc.max_yaw_rate),
    )


@jit
def _torques(
    s: FloatArray, p_d: float, q_d: float, r_d: float, kc: ControllerConsts, ko: OctorotorConsts
) -> tuple[float, float, float]:
    """Torques that give the wished angular accelerations under eq. (2) (step 5)."""
    p, q, r = s[IDX_P], s[IDX_Q], s[IDX_R]
    ixx, iyy, izz, arm = ko.ixx_kg_m2, ko.iyy_kg_m2, ko.izz_kg_m2, ko.arm_length_m
    alpha_p = kc.rate_gain_rp * (p_d - p)
    alpha_q = kc.rate_gain_rp * (q_d - q)
    alpha_r = kc.rate_gain_yaw * (r_d - r)
    tau_phi = (ixx * alpha_p - (iyy - izz) * q * r) / arm
    tau_theta = (iyy * alpha_q - (izz - ixx) * p * r) / arm
    tau_psi = (izz * alpha_r - (ixx - iyy) * p * q) / arm
    return tau_phi, tau_theta, tau_psi


@jit
def control_into(
    s: FloatArray,
    p_target: FloatArray,
    v_target: FloatArray,
    yaw_target: float,
    mode: int,
    integ: FloatArray,
    kc: ControllerConsts,
    ko: OctorotorConsts,
    cmd: FloatArray,
) -> None:
    """One controller period for one vehicle: writes the wished ``cmd : (4,)`` = (T, tau).

    ``s : (12,)`` state, ``integ : (N_MEMORY,)`` this vehicle's integrator (updated). The
    command is not yet saturated (see :func:`ridsafe.sim_backend.actuation.actuate_into`).
    """
    vx, vy, vz, ffx, ffy, ffz, xy_lim, z_lim = _velocity_command(s, p_target, v_target, mode, kc)
    ax, ay, az = _accel_command(
        s, (vx, vy, vz), (ffx, ffy, ffz), (xy_lim, z_lim), integ, kc, ko.gravity_m_s2
    )
    has_yaw = (mode & MODE_YAW) != 0
    heading = yaw_target if has_yaw else s[IDX_PSI]
    phi_d, theta_d, cmd[0] = _attitude_and_thrust(s, ax, ay, az, heading, kc, ko)
    p_d, q_d, r_d = _body_rate_command(s, phi_d, theta_d, yaw_target, has_yaw, kc)
    cmd[1], cmd[2], cmd[3] = _torques(s, p_d, q_d, r_d, kc, ko)
