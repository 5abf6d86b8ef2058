"""The adversaries a scenario family draws per seed (``FamilyConfig``'s ``adversaries`` keys).

Spoofer k (serial ``RSAF8`` + ``00000666 + k``) draws a motion kind from ``motions`` and a claim
kind from ``claims`` (uniformly, from its own stream ``scenario/adversary/<k>``, so the draw
of one spoofer does not move when the count or the others' kinds change):

- ``line``: the family's aimed line (the one the nominal traffic meets most; spoofer 0 uses
  the family's own candidate lines, so the default draw is the one it always was);
- ``waypoints``: ``waypoint_count`` points uniform over the middle of the area, at the
  spoofer's altitude (a path crossing the traffic);
- ``orbit``: a circle of ``orbit_radius_m`` over a depot drawn at random;
- ``pursue``: a benign aircraft drawn at random, at ``pursue_speed_m_s``, from the area's edge.

Claims: ``offset`` (the family's offset), ``drift`` (``drift_rate_m_s`` in a random horizontal
direction from ``drift_start_s``, capped at ``drift_max_offset_m``), ``mimic`` (a random benign
aircraft, ``mimic_delay_s`` late), ``fixed`` (a random point of the area at altitude).
Power: ``tx_power_kind`` fixed (``tx_power_dbm``, default the radio's) or random (mean
``tx_power_dbm`` or the radio's, ``tx_power_sigma_db``).

Ghost g (serial ``00000777 + g``): a transmitter on the ground (``ghost_transmitter_z_m``) at a
random place, claiming ``waypoint_count`` points crossing the area at ``ghost_speed_m_s``.

Bystander b (serial ``00000888 + b``): a third party's aircraft that tells the truth (claim
``truth``), crossing the whole area on a straight line at the spoofers' altitude and speed,
from a random point of its edge to about the opposite one (its own stream
``scenario/bystander/<b>``). The GCS knows nothing of it; an alert on it is a false alert.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from ridsafe.common import rng
from ridsafe.common.adversary import (
    ClaimConfig,
    GhostConfig,
    MotionConfig,
    SpooferConfig,
    TxPowerConfig,
)
from ridsafe.common.checks import check_at_least, check_in_interval, check_non_negative
from ridsafe.common.errors import FieldValueError
from ridsafe.common.scenario import AircraftConfig, Vec3, cta2063_serial

SERIAL_MAKER = "RSAF"
FIRST_SPOOFER_NUMBER = 666
FIRST_GHOST_NUMBER = 777
FIRST_BYSTANDER_NUMBER = 888
_MOTIONS = ("line", "waypoints", "orbit", "pursue")
_CLAIMS = ("offset", "drift", "mimic", "fixed")


#: Named cells (``preset``): the kind keys each sets (one sweep axis, one cell per attack).
PRESETS: dict[str, dict[str, Any]] = {
    "line": {},
    "pursue": {"motions": ("pursue",)},
    "orbit": {"motions": ("orbit",)},
    "waypoints": {"motions": ("waypoints",)},
    "drift": {"claims": ("drift",)},
    "mimic": {"claims": ("mimic",)},
    "fixed": {"claims": ("fixed",)},
    "random-power": {"tx_power_kind": "random"},
    "silent": {"silent_intervals_s": ((40.0, 55.0),)},
    "two-spoofers": {"spoofer_count": 2},
    "two-ghosts": {"ghost_count": 2},
    "bystander": {"bystander_count": 1},
    "pursue-drift": {"motions": ("pursue",), "claims": ("drift",)},
    "mixed": {
        "spoofer_count": 3,
        "motions": _MOTIONS,
        "claims": _CLAIMS,
        "tx_power_kind": "random",
        "ghost_count": 1,
    },
}


@dataclass(frozen=True)
class AdversaryDraw:
    """How many spoofers, ghosts and bystanders a family scenario has, and of which kinds.
    ``preset`` (a name of ``PRESETS``) sets the kind keys of one named cell over the ones
    given."""

    preset: str = ""
    spoofer_count: int = 1
    motions: tuple[str, ...] = ("line",)
    claims: tuple[str, ...] = ("offset",)
    tx_power_kind: Literal["fixed", "random"] = "fixed"
    tx_power_dbm: float | None = None  # None: the radio's
    tx_power_sigma_db: float = 6.0
    silent_intervals_s: tuple[tuple[float, float], ...] = ()
    ghost_count: int = 0
    bystander_count: int = 0
    ghost_transmitter_z_m: float = 2.0
    ghost_speed_m_s: float = 7.0
    waypoint_count: int = 4
    orbit_radius_m: float = 60.0
    pursue_speed_m_s: float = 6.0
    drift_rate_m_s: float = 2.0
    drift_start_s: float = 10.0
    drift_max_offset_m: float = 300.0
    mimic_delay_s: float = 10.0

    def __post_init__(self) -> None:
        if self.preset and self.preset not in PRESETS:
            raise FieldValueError(
                "preset", f"unknown preset {self.preset!r} (known: {list(PRESETS)})"
            )
        check_at_least("spoofer_count", self.spoofer_count, 0)
        check_at_least("ghost_count", self.ghost_count, 0)
        check_at_least("bystander_count", self.bystander_count, 0)
        check_at_least("waypoint_count", self.waypoint_count, 2)
        for name, kinds, known in (
            ("motions", self.motions, _MOTIONS),
            ("claims", self.claims, _CLAIMS),
        ):
            if not kinds:
                raise FieldValueError(name, "need at least one kind")
            for i, kind in enumerate(kinds):
                if kind not in known:
                    raise FieldValueError(f"{name}[{i}]", f"unknown kind {kind!r} (known: {known})")
        for name in ("orbit_radius_m", "pursue_speed_m_s", "ghost_speed_m_s", "drift_max_offset_m"):
            check_in_interval(name, getattr(self, name), 0.0, 10_000.0)
        for name in ("drift_rate_m_s", "drift_start_s", "mimic_delay_s", "tx_power_sigma_db"):
            check_non_negative(name, getattr(self, name))

    def resolved(self) -> AdversaryDraw:
        """The draw with its preset's keys applied."""
        if not self.preset:
            return self
        return dataclasses.replace(self, preset="", **PRESETS[self.preset])

    @property
    def is_default(self) -> bool:
        """One aimed-line offset spoofer at fixed power, no ghosts and no bystanders: the
        family as it was."""
        return not self.preset and self == AdversaryDraw(tx_power_dbm=self.tx_power_dbm)


def spoofer_serial(k: int) -> str:
    return cta2063_serial(SERIAL_MAKER, f"{FIRST_SPOOFER_NUMBER + k:08d}")


def draw_spoofer(
    k: int,
    seed: int,
    aimed_line: SpooferConfig,
    aircraft: tuple[AircraftConfig, ...],
    depots_enu_m: tuple[Vec3, ...],
    half_width_m: float,
    alt_m: float,
    radio_tx_power_dbm: float,
    draw: AdversaryDraw,
) -> SpooferConfig:
    """Spoofer ``k`` of the seed (``aimed_line``: its line if it draws a ``line``)."""
    g = rng.stream(seed, f"scenario/adversary/{k}")
    u = g.random(16)  # a fixed number of draws, whatever the kinds
    motion_kind = draw.motions[int(u[0] * len(draw.motions))]
    claim_kind = draw.claims[int(u[1] * len(draw.claims))]
    target = aircraft[int(u[2] * len(aircraft))].serial
    w = 0.6 * half_width_m
    motion: MotionConfig
    if motion_kind == "line":
        motion = aimed_line.resolved_motion
    elif motion_kind == "waypoints":
        points = g.uniform(-w, w, (draw.waypoint_count, 2))
        motion = MotionConfig(
            "waypoints", aimed_line.speed_m_s, waypoints_enu_m=_at_alt(points, alt_m)
        )
    elif motion_kind == "orbit":
        depot = depots_enu_m[int(u[3] * len(depots_enu_m))]
        motion = MotionConfig(
            "orbit",
            aimed_line.speed_m_s,
            centre_enu_m=(depot[0], depot[1], alt_m),
            radius_m=draw.orbit_radius_m,
            clockwise=bool(u[4] < 0.5),
        )
    else:
        heading = 2 * math.pi * u[5]
        start = (1.05 * half_width_m * math.cos(heading), 1.05 * half_width_m * math.sin(heading))
        motion = MotionConfig(
            "pursue",
            draw.pursue_speed_m_s,
            start_enu_m=_vec((*start, alt_m)),
            target_serial=target,
            standoff_m=0.0,
        )
    claim = _claim(claim_kind, u, target, aimed_line, w, alt_m, draw)
    power = None
    if draw.tx_power_kind == "random":
        mean = radio_tx_power_dbm if draw.tx_power_dbm is None else draw.tx_power_dbm
        power = TxPowerConfig("random", mean_dbm=mean, sigma_db=draw.tx_power_sigma_db)
    return SpooferConfig(
        serial=spoofer_serial(k),
        tx_power_dbm=draw.tx_power_dbm if power is None else None,
        motion=motion,
        claim=claim,
        tx_power=power,
        silent_intervals_s=draw.silent_intervals_s,
    )


def _claim(
    kind: str,
    u: np.ndarray,
    target: str,
    aimed_line: SpooferConfig,
    w: float,
    alt_m: float,
    draw: AdversaryDraw,
) -> ClaimConfig:
    if kind == "offset":
        return ClaimConfig("offset", offset_enu_m=aimed_line.offset_enu_m)
    if kind == "drift":
        angle = 2 * math.pi * u[6]
        rate = (draw.drift_rate_m_s * math.cos(angle), draw.drift_rate_m_s * math.sin(angle), 0.0)
        return ClaimConfig(
            "drift",
            rate_enu_m_s=_vec(rate),
            start_s=draw.drift_start_s,
            max_offset_m=draw.drift_max_offset_m,
        )
    if kind == "mimic":
        return ClaimConfig("mimic", target_serial=target, delay_s=draw.mimic_delay_s)
    at = ((2 * u[7] - 1) * w, (2 * u[8] - 1) * w, alt_m)
    return ClaimConfig("fixed", at_enu_m=_vec(at))


def draw_ghost(
    k: int, seed: int, half_width_m: float, alt_m: float, draw: AdversaryDraw
) -> GhostConfig:
    """Ghost ``k`` of the seed: a ground transmitter claiming a path across the area."""
    g = rng.stream(seed, f"scenario/ghost/{k}")
    w = 0.6 * half_width_m
    where = g.uniform(-0.9 * half_width_m, 0.9 * half_width_m, 2)
    points = g.uniform(-w, w, (draw.waypoint_count, 2))
    return GhostConfig(
        serial=cta2063_serial(SERIAL_MAKER, f"{FIRST_GHOST_NUMBER + k:08d}"),
        transmitter_enu_m=_vec((where[0], where[1], draw.ghost_transmitter_z_m)),
        claim=ClaimConfig(
            "waypoints", waypoints_enu_m=_at_alt(points, alt_m), speed_m_s=draw.ghost_speed_m_s
        ),
        tx_power=None
        if draw.tx_power_dbm is None
        else TxPowerConfig("fixed", dbm=draw.tx_power_dbm),
    )


def draw_bystander(
    k: int, seed: int, half_width_m: float, alt_m: float, speed_m_s: float
) -> SpooferConfig:
    """Bystander ``k`` of the seed: an honest aircraft crossing the area edge to edge."""
    g = rng.stream(seed, f"scenario/bystander/{k}")
    entry = 2 * math.pi * float(g.random())
    exit_ = entry + math.pi + float(g.uniform(-0.5, 0.5))
    r = 1.05 * half_width_m
    return SpooferConfig(
        serial=cta2063_serial(SERIAL_MAKER, f"{FIRST_BYSTANDER_NUMBER + k:08d}"),
        motion=MotionConfig(
            "line",
            speed_m_s,
            start_enu_m=_vec((r * math.cos(entry), r * math.sin(entry), alt_m)),
            goal_enu_m=_vec((r * math.cos(exit_), r * math.sin(exit_), alt_m)),
        ),
        claim=ClaimConfig("truth"),
    )


def _at_alt(points: np.ndarray, alt_m: float) -> tuple[Vec3, ...]:
    return tuple(_vec((p[0], p[1], alt_m)) for p in points)


def _vec(p: tuple[float, ...] | np.ndarray) -> Vec3:
    return (round(float(p[0]), 3), round(float(p[1]), 3), round(float(p[2]), 3))
