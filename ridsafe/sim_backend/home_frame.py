"""The exact map between the scenario ENU frame and one vehicle's local NED frame at its home."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ridsafe.common import frames

FloatArray = NDArray[np.float64]


class HomeFrame:
    """Exact map between the scenario ENU frame and a vehicle's local NED frame at its home.

    Both are rigid transforms of ECEF, so ``p_ned = R p_enu + t`` exactly; R and t are read
    off the frames module by mapping the origin and three 1 km axis points.
    """

    def __init__(self, scenario_origin: frames.GeodeticOrigin, home_enu_m: ArrayLike) -> None:
        home = np.asarray(home_enu_m, dtype=np.float64)
        lat, lon, alt = frames.enu_to_geodetic(scenario_origin, home)
        self.home_geodetic = frames.GeodeticOrigin(float(lat), float(lon), float(alt))
        self.home_enu_m = home
        probe = np.vstack([np.zeros(3), 1000.0 * np.eye(3)])
        plat, plon, palt = frames.enu_to_geodetic(scenario_origin, probe)
        ned = frames.geodetic_to_ned(self.home_geodetic, plat, plon, palt)
        self._t = ned[0]
        self._r = (ned[1:] - ned[0]).T / 1000.0  # columns: images of the ENU unit axes

    def enu_to_local_ned(self, p_enu_m: ArrayLike) -> FloatArray:
        """Scenario ENU position(s) (..., 3) -> local NED (..., 3)."""
        out: FloatArray = np.asarray(p_enu_m, dtype=np.float64) @ self._r.T + self._t
        return out

    def local_ned_to_enu(self, p_ned_m: ArrayLike) -> FloatArray:
        out: FloatArray = (np.asarray(p_ned_m, dtype=np.float64) - self._t) @ self._r
        return out

    def vel_enu_to_ned(self, v_enu_m_s: ArrayLike) -> FloatArray:
        out: FloatArray = np.asarray(v_enu_m_s, dtype=np.float64) @ self._r.T
        return out

    def vel_ned_to_enu(self, v_ned_m_s: ArrayLike) -> FloatArray:
        out: FloatArray = np.asarray(v_ned_m_s, dtype=np.float64) @ self._r
        return out
