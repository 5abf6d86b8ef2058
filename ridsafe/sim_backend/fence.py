"""The geofence of the sim autopilot, as ArduCopter's ``FENCE_*`` parameters describe it.

With ``FENCE_ENABLE`` 1, an armed vehicle in the air is checked every tick against the fences
``FENCE_TYPE`` selects (a bitmask, ArduCopter's values):

- 1 maximum altitude: higher than ``FENCE_ALT_MAX`` (m) above home;
- 2 circle: farther than ``FENCE_RADIUS`` (m) from home, horizontally;
- 4 polygon: outside an inclusion polygon of the uploaded fence list
  (MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION items, ``param1`` the vertex count), or outside
  an inclusion circle (MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, ``param1`` the radius).

On a new breach the autopilot says so (STATUSTEXT "Fence Breach: ...") and does
``FENCE_ACTION``: 0 report only, 1 RTL, 2 LAND, 3 RTL (no SmartRTL here), 4 BRAKE, 5 LAND (no
SmartRTL). A vehicle already in the mode the action picks is left alone. While breached the
SYS_STATUS geofence health bit is clear; back inside, the breach clears ("Fence breach
cleared"). ``FENCE_ENABLE`` 0 (ArduCopter's default) checks nothing.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ridsafe.common import frames
from ridsafe.common import messages as m
from ridsafe.common.messages import CopterMode
from ridsafe.common.protocol_messages import MissionType
from ridsafe.sim_backend.mission_protocol import StoredItem

if TYPE_CHECKING:
    from ridsafe.sim_backend.autopilot import Autopilot, VehicleSample

__all__ = ["Fence", "FenceAction", "FenceKind"]

POLYGON_VERTEX_INCLUSION = 5001
CIRCLE_INCLUSION = 5003


class FenceKind(enum.IntFlag):
    NONE = 0
    ALT_MAX = 1
    CIRCLE = 2
    POLYGON = 4


KIND_NAMES = {FenceKind.ALT_MAX: "altitude", FenceKind.CIRCLE: "circle",
              FenceKind.POLYGON: "polygon"}  # fmt: skip


class FenceAction(enum.IntEnum):
    REPORT_ONLY = 0
    RTL_OR_LAND = 1
    ALWAYS_LAND = 2
    SMART_RTL_OR_RTL = 3
    BRAKE_OR_LAND = 4
    SMART_RTL_OR_LAND = 5


# what the sim does for each action (it has RTL, LAND and BRAKE, no SmartRTL)
ACTION_MODE: dict[FenceAction, CopterMode | None] = {
    FenceAction.REPORT_ONLY: None,
    FenceAction.RTL_OR_LAND: CopterMode.RTL,
    FenceAction.ALWAYS_LAND: CopterMode.LAND,
    FenceAction.SMART_RTL_OR_RTL: CopterMode.RTL,
    FenceAction.BRAKE_OR_LAND: CopterMode.BRAKE,
    FenceAction.SMART_RTL_OR_LAND: CopterMode.LAND,
}


@dataclass
class Fence:
    """One vehicle's fence state: which fences are breached now."""

    breached: FenceKind = FenceKind.NONE
    breaches: int = 0

    @staticmethod
    def enabled(ap: Autopilot) -> bool:
        return ap.params.get("FENCE_ENABLE") >= 1

    def healthy(self) -> bool:
        return self.breached == FenceKind.NONE

    def update(self, now_s: float, sample: VehicleSample, ap: Autopilot) -> None:
        """Check the fences once (armed and flying) and act on a new breach."""
        if not self.enabled(ap) or sample.on_ground:
            if self.breached:
                self.breached = FenceKind.NONE
            return
        now = self._breached_now(sample, ap)
        new = now & ~self.breached
        if self.breached and not now:
            ap.say(m.MavSeverity.INFO, "Fence breach cleared")
        self.breached = now
        if new:
            self._act(now_s, new, sample, ap)

    def _breached_now(self, sample: VehicleSample, ap: Autopilot) -> FenceKind:
        kinds = FenceKind(int(ap.params.get("FENCE_TYPE")) & 0x7)
        offset = sample.p_enu_m - ap.home.home_enu_m
        out = FenceKind.NONE
        if FenceKind.ALT_MAX in kinds and offset[2] > ap.params.get("FENCE_ALT_MAX"):
            out |= FenceKind.ALT_MAX
        if FenceKind.CIRCLE in kinds and math.hypot(offset[0], offset[1]) > ap.params.get(
            "FENCE_RADIUS"
        ):
            out |= FenceKind.CIRCLE
        if FenceKind.POLYGON in kinds and not self._inside_uploaded(offset[:2], ap):
            out |= FenceKind.POLYGON
        return out

    def _act(self, now_s: float, new: FenceKind, sample: VehicleSample, ap: Autopilot) -> None:
        self.breaches += 1
        action = FenceAction(int(ap.params.get("FENCE_ACTION")))
        mode = ACTION_MODE[action]
        names = ", ".join(name for kind, name in KIND_NAMES.items() if kind in new)
        ap.say(m.MavSeverity.CRITICAL, f"Fence Breach: {names}; {action.name}")
        ap.record_event(
            {"event": "fence_breach", "fences": names, "action": action.name.lower(),
             "t_s": now_s}
        )  # fmt: skip
        if mode is not None and ap.mode is not mode:
            ap.enter_failsafe_mode(mode, sample)

    # -- the uploaded fence list ----------------------------------------------------------------

    def _inside_uploaded(self, p_en_m: np.ndarray, ap: Autopilot) -> bool:
        """Inside every inclusion polygon and circle of the fence list (True if it has none)."""
        shapes = _inclusions(ap.missions.lists[MissionType.FENCE], ap)
        return all(_inside(p_en_m, shape, radius) for shape, radius in shapes)


def _inclusions(items: Sequence[StoredItem], ap: Autopilot) -> list[tuple[np.ndarray, float]]:
    """(vertices (N, 2) east/north m, 0) per inclusion polygon; (centre (1, 2), r) per circle."""
    home = ap.home.home_geodetic
    shapes: list[tuple[np.ndarray, float]] = []
    vertices: list[tuple[float, float]] = []
    for item in items:
        command, params = item.command, item.params
        lat, lon = float(params[4]), float(params[5])
        ned = frames.geodetic_to_ned(home, lat, lon, home.alt_m)
        east_north = (float(ned[1]), float(ned[0]))
        if command == POLYGON_VERTEX_INCLUSION:
            vertices.append(east_north)
            if len(vertices) >= max(int(params[0]), 3):
                shapes.append((np.array(vertices), 0.0))
                vertices = []
        elif command == CIRCLE_INCLUSION:
            shapes.append((np.array([east_north]), float(params[0])))
    return shapes


def _inside(p: np.ndarray, shape: np.ndarray, radius: float) -> bool:
    if radius > 0.0:
        return bool(math.hypot(*(p - shape[0])) <= radius)
    inside = False
    n = len(shape)
    for k in range(n):
        (x1, y1), (x2, y2) = shape[k], shape[(k + 1) % n]
        if (y1 > p[1]) != (y2 > p[1]):
            x_cross = x1 + (p[1] - y1) * (x2 - x1) / (y2 - y1)
            if p[0] < x_cross:
                inside = not inside
    return inside
