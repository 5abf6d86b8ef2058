"""The aircraft as its autopilot reports it: position, velocity, home, time, clock offset.

``OwnTelemetry`` keeps the latest of each autopilot message with the companion time it came;
everything the companion says about itself (its Remote ID, where a frame was heard, the
planner's input) is computed from it.

Receiver position (``ReceiverFix``): the latest GLOBAL_POSITION_INT, moved along its NED
velocity to the receive time (at most ``max_extrapolation_s``), with the WGS-84 radii of
curvature::

    lat' = lat + v_n dt / (M + h),   lon' = lon + v_e dt / ((N + h) cos lat),   h' = h - v_d dt
    M = a (1 - e^2) / (1 - e^2 sin^2 lat)^(3/2),   N = a / (1 - e^2 sin^2 lat)^(1/2)

(exact to well below a millimetre over the < 10 m an aircraft moves between two fixes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ridsafe.common import frames, rid
from ridsafe.common import messages as m
from ridsafe.common.frozen import quick_init

__all__ = ["CLOCK_RESET_S", "OwnTelemetry", "ReceiverFix"]

#: A telemetry clock sample this far below the offset estimate: the autopilot rebooted.
CLOCK_RESET_S = 1.0


@quick_init
@dataclass(frozen=True, slots=True)
class ReceiverFix:
    """The latest GLOBAL_POSITION_INT: WGS-84 position, NED velocity, companion time it came."""

    t_s: float
    lat_deg: float
    lon_deg: float
    alt_m: float
    v_ned_m_s: m.Vec3

    def at(self, t_s: float, max_extrapolation_s: float) -> tuple[float, float, float]:
        """(lat_deg, lon_deg, alt_m) at ``t_s``, extrapolated along the velocity (bounded)."""
        dt = min(max(t_s - self.t_s, -max_extrapolation_s), max_extrapolation_s)
        vn, ve, vd = self.v_ned_m_s
        lat = math.radians(self.lat_deg)
        w = 1.0 - frames.WGS84_E2 * math.sin(lat) ** 2
        radius_n = frames.WGS84_A_M / math.sqrt(w)
        radius_m = frames.WGS84_A_M * (1.0 - frames.WGS84_E2) / w**1.5
        dlat = vn * dt / (radius_m + self.alt_m)
        dlon = ve * dt / ((radius_n + self.alt_m) * max(math.cos(lat), 1e-9))
        return (
            self.lat_deg + math.degrees(dlat),
            self.lon_deg + math.degrees(dlon),
            self.alt_m - vd * dt,
        )


def _vec3(values: NDArray[np.float64] | tuple[float, ...]) -> m.Vec3:
    return (float(values[0]), float(values[1]), float(values[2]))


class OwnTelemetry:
    """The aircraft as its autopilot reports it, with the companion time each report came.

    Besides the receiver's position (``fix``) it gives the companion its own Remote ID state,
    UNIX time (SYSTEM_TIME advanced by the time since it came), the geodetic <-> local NED
    conversions about HOME_POSITION (shifted by home's local x, y, z) and the estimate of the
    autopilot's clock: ``sim_time(now) = now + offset``, offset = the largest
    ``time_boot - arrival`` seen (the sample with the least latency), restarted when a sample
    falls ``CLOCK_RESET_S`` below it (the autopilot rebooted).
    """

    def __init__(self) -> None:
        self.heartbeat: m.Heartbeat | None = None
        self.heartbeat_s: float | None = None
        self.gpi: m.GlobalPositionInt | None = None
        self.gpi_s = 0.0
        self.lpn: m.LocalPositionNed | None = None
        self.home: m.HomePosition | None = None
        self.home_origin: frames.GeodeticOrigin | None = None
        self.system_time: m.SystemTime | None = None
        self.system_time_s = 0.0
        self.clock_offset_s: float | None = None

    def observe_clock(self, now_s: float, time_boot_s: float) -> None:
        sample = time_boot_s - now_s
        offset = self.clock_offset_s
        if offset is None or sample > offset or sample < offset - CLOCK_RESET_S:
            self.clock_offset_s = sample

    def sim_time(self, now_s: float) -> float:
        """``now_s`` on the autopilot's clock (itself until telemetry has come)."""
        return now_s if self.clock_offset_s is None else now_s + self.clock_offset_s

    def set_home(self, home: m.HomePosition) -> None:
        origin = frames.GeodeticOrigin(home.lat_deg, home.lon_deg, home.alt_msl_m)
        if origin != self.home_origin:
            self.home_origin = origin  # only a changed home: origins key a cache in frames
        self.home = home

    @property
    def armed(self) -> bool:
        return self.heartbeat is not None and self.heartbeat.armed

    def unix_s(self, now_s: float) -> float | None:
        """UNIX time now: SYSTEM_TIME advanced by the time since it came (None: unknown)."""
        st = self.system_time
        if st is None or st.time_unix_s <= 0.0:
            return None
        return st.time_unix_s + (now_s - self.system_time_s)

    def fix(self) -> ReceiverFix | None:
        gpi = self.gpi
        if gpi is None:
            return None
        return ReceiverFix(self.gpi_s, gpi.lat_deg, gpi.lon_deg, gpi.alt_msl_m, gpi.v_ned_m_s)

    def to_local(self, lat_deg: float, lon_deg: float, alt_m: float) -> m.Vec3:
        """WGS-84 -> the autopilot's local NED (needs HOME_POSITION)."""
        if self.home_origin is None or self.home is None:
            raise LookupError("no HOME_POSITION yet")
        e, n, u = frames.geodetic_to_enu_point(self.home_origin, lat_deg, lon_deg, alt_m)
        hn, he, hd = self.home.p_ned_m
        return (n + hn, e + he, -u + hd)

    @property
    def local_frame(self) -> tuple[frames.GeodeticOrigin, m.Vec3] | None:
        """What ``to_local`` depends on (None before HOME_POSITION): equal frames, equal
        conversions."""
        if self.home_origin is None or self.home is None:
            return None
        return self.home_origin, self.home.p_ned_m

    def to_geodetic(self, p_ned_m: m.Vec3) -> tuple[float, float, float]:
        if self.home_origin is None or self.home is None:
            raise LookupError("no HOME_POSITION yet")
        hn, he, hd = self.home.p_ned_m
        north, east, down = p_ned_m[0] - hn, p_ned_m[1] - he, p_ned_m[2] - hd
        return frames.enu_to_geodetic_point(self.home_origin, east, north, -down)

    def rid_state(
        self, now_s: float, emergency: bool, max_extrapolation_s: float
    ) -> rid.OwnState | None:
        unix_s, fix, gpi = self.unix_s(now_s), self.fix(), self.gpi
        if unix_s is None or fix is None or gpi is None:
            return None
        lat, lon, alt = fix.at(now_s, max_extrapolation_s)
        height = gpi.relative_alt_m + (alt - gpi.alt_msl_m)
        speed = math.hypot(*gpi.v_ned_m_s)
        airborne = self.armed and (height > 0.5 or speed > 0.5)
        return rid.OwnState(unix_s, lat, lon, alt, height, gpi.v_ned_m_s, airborne, emergency)
