"""A spoofer's (or ghost's) Remote ID broadcaster, and the straight-line mission.

The default spoofer's autopilot flies ``StraightLineMission`` in AUTO mode (it avoids nobody);
its broadcaster claims its true state plus a constant ENU offset:

    claimed_p_enu(t) = p_enu(t) + offset_enu,      claimed_v = v (its true velocity)

at the cadence of an honest aircraft (LOCATION every 1 s, BASIC_ID / SYSTEM / OPERATOR_ID
every 3 s), so only the physics of the radio can give it away. Other claims (drift, mimic,
fixed, a made-up path: ``ridsafe.sim_backend.adversary_claim``) plug in as ``claim``, a
function ``(now_s, p, v) -> (claimed p, claimed v)``; in ``silent_intervals_s`` it sends
nothing (its slots pass unused).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ridsafe.common import frames, rid
from ridsafe.common import messages as m
from ridsafe.common.adversary import silent_at

FloatArray = NDArray[np.float64]
ClaimFunction = Callable[[float, FloatArray, FloatArray], tuple[FloatArray, FloatArray]]


class StraightLineMission:
    """Target on the segment start -> goal, moving at ``speed_m_s`` from ``t0_s``; holds the
    goal once there. Position and velocity feed-forward, so the controller tracks the line."""

    def __init__(
        self, start_enu_m: ArrayLike, goal_enu_m: ArrayLike, speed_m_s: float, t0_s: float = 0.0
    ) -> None:
        self.start = np.asarray(start_enu_m, dtype=np.float64)
        self.goal = np.asarray(goal_enu_m, dtype=np.float64)
        delta = self.goal - self.start
        self.length_m = float(np.linalg.norm(delta))
        self.direction = delta / self.length_m if self.length_m > 0 else np.zeros(3)
        self.speed_m_s = speed_m_s
        self.t0_s = t0_s

    def target(self, now_s: float) -> tuple[FloatArray, FloatArray]:
        if now_s < self.t0_s:
            return self.start.copy(), np.zeros(3)
        travelled = min((now_s - self.t0_s) * self.speed_m_s, self.length_m)
        if travelled >= self.length_m:
            return self.goal.copy(), np.zeros(3)
        return self.start + travelled * self.direction, self.speed_m_s * self.direction


class SpooferBroadcaster:
    """The spoofer's own RID messages: true state + constant offset, honest cadence."""

    def __init__(
        self,
        serial: str,
        offset_enu_m: ArrayLike,
        origin: frames.GeodeticOrigin,
        start_unix_s: float,
        ground_enu_m: ArrayLike,
        phase_s: float = 0.0,
        claim: ClaimFunction | None = None,
        silent_intervals_s: tuple[tuple[float, float], ...] = (),
    ) -> None:
        self.serial = serial
        self.claim = claim
        self.silent_intervals_s = silent_intervals_s
        self.offset_enu_m = np.asarray(offset_enu_m, dtype=np.float64)
        self.origin = origin
        self.start_unix_s = start_unix_s
        ground = np.asarray(ground_enu_m, dtype=np.float64)
        lat, lon, alt = frames.enu_to_geodetic(origin, ground)
        self._operator = (float(lat), float(lon), float(alt))
        self._ground_z_m = float(ground[2])
        self._next_location_s = phase_s
        self._next_static_s = phase_s

    def claimed_p_enu_m(self, p_enu_m: FloatArray) -> FloatArray:
        claimed: FloatArray = p_enu_m + self.offset_enu_m
        return claimed

    def claimed_state(
        self, now_s: float, p_enu_m: FloatArray, v_enu_m_s: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """What the RID says at ``now_s`` given the true state: (position, velocity) ENU."""
        if self.claim is None:
            return self.claimed_p_enu_m(p_enu_m), v_enu_m_s
        return self.claim(now_s, p_enu_m, v_enu_m_s)

    def due(self, now_s: float, p_enu_m: FloatArray, v_enu_m_s: FloatArray) -> list[m.Message]:
        """The messages to hand to the spoofer's transponder at ``now_s``."""
        out: list[m.Message] = []
        unix_s = self.start_unix_s + now_s
        if self.silent_intervals_s and silent_at(self.silent_intervals_s, now_s):
            if now_s >= self._next_static_s - 1e-9:
                self._next_static_s = _next_slot(
                    self._next_static_s, now_s, rid.RID_STATIC_PERIOD_S
                )
            if now_s >= self._next_location_s - 1e-9:
                self._next_location_s = _next_slot(
                    self._next_location_s, now_s, rid.RID_LOCATION_PERIOD_S
                )
            return out
        if now_s >= self._next_static_s - 1e-9:
            self._next_static_s = _next_slot(self._next_static_s, now_s, rid.RID_STATIC_PERIOD_S)
            out.append(rid.basic_id(self.serial))
            out.append(rid.system(unix_s, *self._operator))
            out.append(rid.operator_id("OPERATOR-SPOOF"))
        if now_s >= self._next_location_s - 1e-9:
            self._next_location_s = _next_slot(
                self._next_location_s, now_s, rid.RID_LOCATION_PERIOD_S
            )
            out.append(rid.location(self._own_state(now_s, unix_s, p_enu_m, v_enu_m_s)))
        return out

    def _own_state(
        self, now_s: float, unix_s: float, p_enu_m: FloatArray, v_enu_m_s: FloatArray
    ) -> rid.OwnState:
        claimed, claimed_v = self.claimed_state(now_s, p_enu_m, v_enu_m_s)
        lat, lon, alt = frames.enu_to_geodetic(self.origin, claimed)
        v_ned = frames.enu_to_ned(claimed_v)
        # The offset spoofer reports its true airborne state; other claims their own.
        moving, moving_v = (p_enu_m, v_enu_m_s) if self.claim is None else (claimed, claimed_v)
        return rid.OwnState(
            unix_s=unix_s,
            lat_deg=float(lat),
            lon_deg=float(lon),
            alt_geodetic_m=float(alt),
            height_m=float(claimed[2] - self._ground_z_m),
            v_ned_m_s=(float(v_ned[0]), float(v_ned[1]), float(v_ned[2])),
            airborne=bool(moving[2] - self._ground_z_m > 0.5 or math.hypot(*moving_v) > 0.2),
        )


def _next_slot(slot_s: float, now_s: float, period_s: float) -> float:
    """The first slot after ``now_s`` on the grid ``slot_s + k period_s`` (missed slots are
    skipped, so a stalled caller never bursts)."""
    missed = math.floor((now_s - slot_s) / period_s + 1e-9)
    return slot_s + (max(missed, 0) + 1) * period_s
