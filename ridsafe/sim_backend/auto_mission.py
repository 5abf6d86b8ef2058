"""AUTO mode flying an uploaded mission, one item at a time, as ArduCopter does.

``NAV_HANDLERS``: MAV_CMD -> handler(mission, item, sample, autopilot) -> True when the item
is done. Supported: NAV_TAKEOFF (climb straight up to ``z`` above home), NAV_WAYPOINT (fly to
lat/lon/alt; done within WPNAV_RADIUS), NAV_LAND (fly to lat/lon if given, then descend and
disarm), NAV_RETURN_TO_LAUNCH (RTL's behaviour). Other commands (DO_*, CONDITION_*) are
skipped, as the sim has nothing they could change. After the last item the vehicle holds.

Altitudes: frames 3 and 6 (relative) are above home; frame 0 / 5 above the WGS-84 ellipsoid
(the sim has no geoid); 10 / 11 (terrain) are taken as relative (the sim's ground is flat at
home height).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ridsafe.common import frames
from ridsafe.sim_backend.commands import VehicleSample
from ridsafe.sim_backend.mission_protocol import (
    NAV_LAND,
    NAV_RETURN_TO_LAUNCH,
    NAV_TAKEOFF,
    NAV_WAYPOINT,
    StoredItem,
)

if TYPE_CHECKING:
    from ridsafe.sim_backend.autopilot import Autopilot

FloatArray = NDArray[np.float64]
ABSOLUTE_ALT_FRAMES = frozenset({0, 5})
TAKEOFF_TOLERANCE_M = 1.0


class AutoMission:
    """The uploaded mission's progress; ``items[k]`` is mission sequence ``k + 1``."""

    def __init__(self, items: Sequence[StoredItem], start_seq: int = 1) -> None:
        self.items = list(items)
        self.index = max(start_seq - 1, 0)
        self.landing = False
        self.entered = False

    @property
    def seq(self) -> int:
        return self.index + 1

    @property
    def finished(self) -> bool:
        return self.index >= len(self.items)

    def update(self, sample: VehicleSample, ap: Autopilot) -> None:
        """One tick: run the current item, advancing past finished and unsupported ones."""
        while not self.finished:
            item = self.items[self.index]
            handler = NAV_HANDLERS.get(item.command)
            if handler is not None and not handler(self, item, sample, ap):
                return
            self.index += 1
            self.entered = False
            ap.missions.current_seq = min(self.seq, len(self.items))
        ap.actuators.set_target(ap.vehicle, position_enu_m=sample.p_enu_m, yaw_rad=sample.psi_rad)

    def target_enu_m(self, item: StoredItem, ap: Autopilot, sample: VehicleSample) -> FloatArray:
        """The item's position in the scenario ENU frame (lat/lon 0: where the vehicle is)."""
        home = ap.home.home_geodetic
        alt = item.params[6]
        alt_msl = alt if item.frame in ABSOLUTE_ALT_FRAMES else home.alt_m + alt
        if item.params[4] == 0.0 and item.params[5] == 0.0:
            here = sample.p_enu_m.copy()
            here[2] = ap.home.home_enu_m[2] + alt if alt > 0 else here[2]
            return here
        p_ned = frames.geodetic_to_ned(home, item.params[4], item.params[5], alt_msl)
        return ap.home.local_ned_to_enu(p_ned)


def _takeoff(mission: AutoMission, item: StoredItem, sample: VehicleSample, ap: Autopilot) -> bool:
    target_z = float(ap.home.home_enu_m[2] + item.params[6])
    if not mission.entered:
        mission.entered = True
        ap.takeoff_alt_enu_m = target_z
        target = sample.p_enu_m.copy()
        target[2] = target_z
        ap.actuators.set_target(ap.vehicle, position_enu_m=target, yaw_rad=sample.psi_rad)
    done = sample.p_enu_m[2] >= target_z - TAKEOFF_TOLERANCE_M
    if done:
        ap.takeoff_alt_enu_m = None
    return bool(done)


def _waypoint(mission: AutoMission, item: StoredItem, sample: VehicleSample, ap: Autopilot) -> bool:
    target = mission.target_enu_m(item, ap, sample)
    if not mission.entered:
        mission.entered = True
        ap.actuators.set_target(ap.vehicle, position_enu_m=target, yaw_rad=sample.psi_rad)
    radius_m = ap.params.get("WPNAV_RADIUS") / 100.0
    return float(np.linalg.norm(sample.p_enu_m - target)) <= max(radius_m, 0.5)


def _land(mission: AutoMission, item: StoredItem, sample: VehicleSample, ap: Autopilot) -> bool:
    if not mission.landing:
        target = mission.target_enu_m(item, ap, sample)
        target[2] = sample.p_enu_m[2]
        if float(np.linalg.norm(sample.p_enu_m[:2] - target[:2])) > 1.0:
            if not mission.entered:
                mission.entered = True
                ap.actuators.set_target(ap.vehicle, position_enu_m=target, yaw_rad=sample.psi_rad)
            return False
        mission.landing = True
        ap.land_here(sample, hold_enu_m=sample.p_enu_m.copy())
        return False
    ap.land_here(sample)
    return False  # the autopilot disarms on the ground; the item never "finishes" in the air


def _rtl(mission: AutoMission, item: StoredItem, sample: VehicleSample, ap: Autopilot) -> bool:
    ap.return_home(sample)
    return False


NavHandler = Callable[[AutoMission, StoredItem, VehicleSample, "Autopilot"], bool]

NAV_HANDLERS: dict[int, NavHandler] = {
    NAV_TAKEOFF: _takeoff,
    NAV_WAYPOINT: _waypoint,
    NAV_LAND: _land,
    NAV_RETURN_TO_LAUNCH: _rtl,
}
