"""Where and when the family's aircraft take off: depots, pads and the launch cadence.

Aircraft ``k`` departs from depot ``k mod D`` (``D`` depots), as launch ``s = k // D`` of that
depot. A depot's pads are its centre, then rings of ``6 q`` pads at radius ``q x
pad_spacing_m`` (q = 1 .. ``max_pad_rings``), in that order, leaving out the pads outside the
area (``|e|, |n| <= half_width_m - pad_margin_m``); launch ``s`` uses pad ``s mod P`` (``P``
pads), so a depot with more launches than pads uses a pad again once its aircraft has gone.

Which pad (``pad_choice``): ``in_turn`` is the order above. ``toward_delivery`` (``DepotPads``)
gives each launch the free pad (none launched within ``pad_reuse_s``) furthest along the
bearing from the depot to its delivery, so a departure leaves the depot's other pads, and the
aircraft parked or lifting off on them, behind it instead of climbing out over them. With
pads in turn most benign-benign NMACs at 32 and 64 aircraft were a lift-off beneath the
depot's previous departure (``docs/results/dense_traffic.md``).

Cadence: every ``launch_interval_s`` while the depot's last launch still falls within
``launch_window_s``; a denser family launches faster, ``interval = launch_window_s / (S - 1)``
for ``S`` launches per depot, so every aircraft is up early enough to deliver within the run.
Within one area the window is what adapts: the area and the depots are the scenario's
geography (a config may give more depots or a larger area, as ``configs/city.yaml`` does, or
let the family copy its area for more aircraft, ``FamilyConfig.tile_capacity``), while the
launch rate is an operator's choice. With the defaults (4 s, 40 s) the
paper's 4-16 aircraft launch exactly as they always did (at most 6 per depot, 20 s).

A family that cannot be drawn is refused (``FamilyDrawError``, naming the keys to change):
an interval below ``min_launch_interval_s`` (too many aircraft per depot), or a pad used again
sooner than ``pad_reuse_s`` after its previous launch.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence
from dataclasses import dataclass

from ridsafe.common.errors import FieldValueError
from ridsafe.common.scenario import Vec3

__all__ = [
    "DepotPads",
    "FamilyDrawError",
    "Launch",
    "LaunchRules",
    "PadChoice",
    "launch_schedule",
    "pad_offsets_enu_m",
]


class PadChoice(enum.Enum):
    """Which of its depot's pads a launch takes (module docstring)."""

    IN_TURN = "in_turn"
    TOWARD_DELIVERY = "toward_delivery"


class FamilyDrawError(FieldValueError):
    """The family cannot draw this many aircraft; the message names the keys to change."""


@dataclass(frozen=True)
class LaunchRules:
    """The family keys that place and time the launches (see the module docstring)."""

    half_width_m: float
    depots_enu_m: tuple[Vec3, ...]
    launch_interval_s: float
    launch_window_s: float
    min_launch_interval_s: float
    pad_spacing_m: float
    max_pad_rings: int
    pad_margin_m: float
    pad_reuse_s: float


@dataclass(frozen=True)
class Launch:
    """One aircraft's take-off: its depot (index), pad (ENU, m) and departure time (s). The
    pad is the one in turn; with ``PadChoice.TOWARD_DELIVERY`` the family takes the pad facing
    the delivery instead (``DepotPads``)."""

    depot_index: int
    pad_enu_m: Vec3
    departure_s: float


def pad_offsets_enu_m(depot_enu_m: Vec3, rules: LaunchRules) -> tuple[Vec3, ...]:
    """The depot's pads inside the area, centre first, then ring by ring (ENU, m)."""
    pads: list[Vec3] = []
    limit_m = rules.half_width_m - rules.pad_margin_m
    for ring in range(rules.max_pad_rings + 1):
        for index in range(max(1, 6 * ring)):
            angle = 2 * math.pi * index / (6 * ring) if ring else 0.0
            e = depot_enu_m[0] + ring * rules.pad_spacing_m * math.cos(angle)
            n = depot_enu_m[1] + ring * rules.pad_spacing_m * math.sin(angle)
            if abs(e) <= limit_m and abs(n) <= limit_m:
                pads.append((e, n, depot_enu_m[2]))
    return tuple(pads)


def launch_interval_s(n_aircraft: int, rules: LaunchRules) -> float:
    """The cadence of every depot: ``launch_interval_s``, or faster to fit the window."""
    per_depot = math.ceil(n_aircraft / len(rules.depots_enu_m))
    interval = rules.launch_interval_s
    if per_depot > 1 and (per_depot - 1) * interval > rules.launch_window_s:
        interval = rules.launch_window_s / (per_depot - 1)
    if interval < rules.min_launch_interval_s:
        raise FamilyDrawError(
            "aircraft",
            f"--aircraft {n_aircraft} needs {per_depot} launches per depot from "
            f"{len(rules.depots_enu_m)} depots within family.launch_window_s="
            f"{rules.launch_window_s:g} s, one every {interval:.2f} s, faster than "
            f"family.min_launch_interval_s={rules.min_launch_interval_s:g} s: fly fewer "
            "aircraft, add depots (family.depots_enu_m), widen the window or give more "
            "aircraft more ground (family.tile_capacity)",
        )
    return interval


def launch_schedule(n_aircraft: int, rules: LaunchRules) -> tuple[Launch, ...]:
    """Every aircraft's depot, pad and departure (module docstring); refuses what cannot fly."""
    if n_aircraft < 1:
        raise FamilyDrawError("aircraft", f"need at least one aircraft, got {n_aircraft}")
    interval = launch_interval_s(n_aircraft, rules)
    n_depots = len(rules.depots_enu_m)
    pads = [pad_offsets_enu_m(d, rules) for d in rules.depots_enu_m]
    for d, depot_pads in enumerate(pads):
        launches = len(range(d, n_aircraft, n_depots))
        if not depot_pads:
            raise FamilyDrawError(
                f"depots_enu_m[{d}]",
                f"no pad of this depot lies inside the area (family.half_width_m="
                f"{rules.half_width_m:g} m less family.pad_margin_m={rules.pad_margin_m:g} m)",
            )
        if launches > len(depot_pads) and len(depot_pads) * interval < rules.pad_reuse_s:
            raise FamilyDrawError(
                "aircraft",
                f"--aircraft {n_aircraft}: depot {d} launches {launches} aircraft from "
                f"{len(depot_pads)} pads every {interval:.2f} s, so a pad is used again after "
                f"{len(depot_pads) * interval:.1f} s < family.pad_reuse_s="
                f"{rules.pad_reuse_s:g} s: fly fewer aircraft, add depots or pads "
                "(family.depots_enu_m, family.max_pad_rings) or widen family.launch_window_s",
            )
    return tuple(
        Launch(k % n_depots, pads[k % n_depots][(k // n_depots) % len(pads[k % n_depots])],
               (k // n_depots) * interval)
        for k in range(n_aircraft)
    )  # fmt: skip


class DepotPads:
    """One depot's pads and when each last launched: the pad a launch toward its delivery
    takes (``PadChoice.TOWARD_DELIVERY``)."""

    def __init__(self, depot_enu_m: Vec3, rules: LaunchRules) -> None:
        self.depot_enu_m = depot_enu_m
        self.pads = pad_offsets_enu_m(depot_enu_m, rules)
        self._reuse_s = rules.pad_reuse_s
        self._last_launch_s: dict[Vec3, float] = {}

    def facing(self, site_enu_m: Sequence[float], departure_s: float) -> Vec3:
        """The free pad furthest along the bearing from the depot to ``site_enu_m`` (the
        first in ``pad_offsets_enu_m`` order on a tie). ``launch_schedule`` refused every
        cadence that could leave no pad free."""
        east_m = site_enu_m[0] - self.depot_enu_m[0]
        north_m = site_enu_m[1] - self.depot_enu_m[1]
        free = [p for p in self.pads if self._free(p, departure_s)]
        if not free:  # the schedule's check makes this unreachable
            raise FamilyDrawError("pad_reuse_s", f"no pad free at {departure_s:g} s")
        return max(
            free,
            key=lambda p: (
                (p[0] - self.depot_enu_m[0]) * east_m + (p[1] - self.depot_enu_m[1]) * north_m
            ),
        )

    def take(self, pad_enu_m: Vec3, departure_s: float) -> None:
        """Launch from ``pad_enu_m`` at ``departure_s`` (launches come in time order)."""
        self._last_launch_s[pad_enu_m] = departure_s

    def _free(self, pad_enu_m: Vec3, departure_s: float) -> bool:
        last_s = self._last_launch_s.get(pad_enu_m)
        return last_s is None or departure_s - last_s >= self._reuse_s - 1e-9
