"""Which SET_POSITION_TARGET_* setpoints ArduCopter's GUIDED mode accepts: the type-mask and
value checks (a rejection is a reason string, None accepts)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ridsafe.common import messages as m
from ridsafe.common.messages import PositionTargetMask as Mask

FloatArray = NDArray[np.float64]

POSITION_BITS = Mask.X_IGNORE | Mask.Y_IGNORE | Mask.Z_IGNORE
VELOCITY_BITS = Mask.VX_IGNORE | Mask.VY_IGNORE | Mask.VZ_IGNORE
ACCEL_BITS = Mask.AX_IGNORE | Mask.AY_IGNORE | Mask.AZ_IGNORE

# SET_POSITION_TARGET_LOCAL_NED frames ArduCopter accepts; body frames rotate by heading.
BODY_FRAMES = frozenset({8, 9})  # MAV_FRAME_BODY_NED, MAV_FRAME_BODY_OFFSET_NED
TARGET_FRAMES = frozenset({m.MavFrame.LOCAL_NED, m.MavFrame.LOCAL_OFFSET_NED, *BODY_FRAMES})


def yaw_rotate(v_frd: FloatArray, heading_rad: float) -> FloatArray:
    """A body-frame (x forward, y right) vector into NED for a vehicle heading ``heading_rad``
    (0 north, clockwise positive); z unchanged."""
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    return np.array([c * v_frd[0] - s * v_frd[1], s * v_frd[0] + c * v_frd[1], v_frd[2]])


def _used(mask: Mask, bits: Mask) -> bool | None:
    """True if all three axes are used, False if all ignored, None if mixed."""
    ignored = mask & bits
    if ignored == bits:
        return False
    return True if not ignored else None


def mask_rejection(
    msg: m.SetPositionTargetLocalNed, max_distance_m: float, max_speed_m_s: float
) -> str | None:
    mask = Mask(msg.type_mask)
    used_pos, used_vel = _used(mask, POSITION_BITS), _used(mask, VELOCITY_BITS)
    if used_pos is None or used_vel is None:
        return f"Target: mask {msg.type_mask} mixes used and ignored axes"
    if (mask & ACCEL_BITS) != ACCEL_BITS:
        return f"Target: mask {msg.type_mask} asks for acceleration"
    if not (used_pos or used_vel):
        return f"Target: mask {msg.type_mask} uses neither pos nor velocity"
    return _value_rejection(msg, used_pos, used_vel, max_distance_m, max_speed_m_s)


def _value_rejection(
    msg: m.SetPositionTargetLocalNed,
    used_pos: bool,
    used_vel: bool,
    max_distance_m: float,
    max_speed_m_s: float,
) -> str | None:
    values: list[float] = []
    if used_pos:
        values.extend(msg.p_ned_m)
    if used_vel:
        values.extend(msg.v_ned_m_s)
    if not (Mask(msg.type_mask) & Mask.YAW_IGNORE):
        values.append(msg.yaw_rad)
    if not all(math.isfinite(v) for v in values):
        return "Target: NaN or infinite value in a used field"
    if used_pos and max(abs(v) for v in msg.p_ned_m) > max_distance_m:
        return f"Target: {max(abs(v) for v in msg.p_ned_m):.3g} m out of range"
    if used_vel and math.hypot(*msg.v_ned_m_s) > max_speed_m_s:
        return f"Target: {math.hypot(*msg.v_ned_m_s):.3g} m/s out of range"
    return None
