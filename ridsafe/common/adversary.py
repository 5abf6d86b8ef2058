"""The adversaries of a scenario: spoofers (aircraft that fly and lie) and ghosts (transmitters
that claim an aircraft that does not exist); and bystanders, aircraft outside the fleet that
tell the truth (a third party's drone: the GCS knows nothing of it, and an alert on it is a
false alert).

A spoofer has three independent parts, each a ``kind`` with its parameters (YAML keys as
written here; a key that does not belong to the chosen kind is an error):

- ``motion`` (how it really flies; it avoids nobody): ``line`` {start_enu_m, goal_enu_m,
  speed_m_s}; ``waypoints`` {waypoints_enu_m, speed_m_s, loop}; ``orbit`` {centre_enu_m,
  radius_m, speed_m_s, clockwise}; ``pursue`` {target_serial, speed_m_s, standoff_m,
  start_enu_m} (flies at the target's true position, stops ``standoff_m`` short).
- ``claim`` (what its Remote ID says): ``offset`` {offset_enu_m}; ``drift`` {rate_enu_m_s,
  start_s, max_offset_m} (honest until ``start_s``, then the offset grows at ``rate_enu_m_s``
  up to ``max_offset_m``); ``mimic`` {target_serial, delay_s} (where that aircraft was
  ``delay_s`` ago); ``fixed`` {at_enu_m} (hovering at one place); ``waypoints``
  {waypoints_enu_m, speed_m_s, loop} (a made-up path; what a ghost claims); ``truth`` {}
  (where it really is: a ``spoofers`` entry with this claim is a *bystander*, not an
  adversary; its role in the log is ``bystander`` and every alert on it is a false alert).
- ``tx_power``: ``fixed`` {dbm} or ``random`` {mean_dbm, sigma_db} (a new power every
  message). Absent: ``tx_power_dbm`` or the radio's default, as for a benign aircraft.

plus ``silent_intervals_s`` (windows [t0, t1] of sim time in which it does not transmit).

The old single-spoofer form (``start_enu_m``, ``goal_enu_m``, ``speed_m_s``, ``offset_enu_m``
at the top of the entry) stays as shorthand for ``motion: line`` + ``claim: offset``.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Literal

from ridsafe.common.checks import (
    check_cta2063_serial,
    check_finite_vector,
    check_in_interval,
    check_non_negative,
)
from ridsafe.common.errors import FieldValueError

Vec3 = tuple[float, float, float]
AREA_LIMIT_M = 100_000.0
MAX_SPOOFER_SPEED_M_S = 20.0

MotionKind = Literal["line", "waypoints", "orbit", "pursue"]
ClaimKind = Literal["offset", "drift", "mimic", "fixed", "waypoints", "truth"]
TxPowerKind = Literal["fixed", "random"]

_MOTION_KEYS: dict[str, tuple[str, ...]] = {
    "line": ("start_enu_m", "goal_enu_m"),
    "waypoints": ("waypoints_enu_m",),
    "orbit": ("centre_enu_m", "radius_m"),
    "pursue": ("target_serial", "start_enu_m"),
}
_MOTION_OPTIONAL: dict[str, tuple[str, ...]] = {
    "line": (),
    "waypoints": ("loop",),
    "orbit": ("clockwise",),
    "pursue": ("standoff_m",),
}
_CLAIM_KEYS: dict[str, tuple[str, ...]] = {
    "offset": ("offset_enu_m",),
    "drift": ("rate_enu_m_s",),
    "mimic": ("target_serial",),
    "fixed": ("at_enu_m",),
    "waypoints": ("waypoints_enu_m", "speed_m_s"),
    "truth": (),
}
_CLAIM_OPTIONAL: dict[str, tuple[str, ...]] = {
    "offset": (),
    "drift": ("start_s", "max_offset_m"),
    "mimic": ("delay_s",),
    "fixed": (),
    "waypoints": ("loop",),
    "truth": (),
}


def _check_kind_keys(
    obj: object,
    kind: str,
    required: tuple[str, ...],
    optional: tuple[str, ...],
    all_keys: tuple[str, ...],
) -> None:
    """Keys of ``kind`` present, keys of other kinds absent (None)."""
    for key in required:
        if getattr(obj, key) is None:
            raise FieldValueError(key, f"required for kind {kind!r}")
    for key in all_keys:
        if key not in required and key not in optional and getattr(obj, key) is not None:
            raise FieldValueError(
                key, f"not a key of kind {kind!r} (its keys: {required + optional})"
            )


def _check_points(name: str, points: tuple[Vec3, ...], minimum: int) -> None:
    if len(points) < minimum:
        raise FieldValueError(name, f"expected at least {minimum} points, got {len(points)}")
    for i, p in enumerate(points):
        check_finite_vector(f"{name}[{i}]", p, AREA_LIMIT_M, " m")


class AdversaryRole(enum.StrEnum):
    """What a transmitter outside the fleet is, as the logs' ``role`` says (a plain string
    there: a record read back compares equal to these)."""

    SPOOFER = "spoofer"  # broadcasts a claim that is not where it is
    BYSTANDER = "bystander"  # an honest aircraft outside the fleet (claim ``truth``)
    GHOST = "ghost"  # a transmitter broadcasting an aircraft that does not exist


@dataclass(frozen=True)
class MotionConfig:
    """How a spoofer really flies (module docstring)."""

    kind: MotionKind
    speed_m_s: float = 7.0
    start_enu_m: Vec3 | None = None
    goal_enu_m: Vec3 | None = None
    waypoints_enu_m: tuple[Vec3, ...] | None = None
    loop: bool | None = None
    centre_enu_m: Vec3 | None = None
    radius_m: float | None = None
    clockwise: bool | None = None
    target_serial: str | None = None
    standoff_m: float | None = None

    def __post_init__(self) -> None:
        keys = (
            "start_enu_m",
            "goal_enu_m",
            "waypoints_enu_m",
            "loop",
            "centre_enu_m",
            "radius_m",
            "clockwise",
            "target_serial",
            "standoff_m",
        )
        _check_kind_keys(
            self, self.kind, _MOTION_KEYS[self.kind], _MOTION_OPTIONAL[self.kind], keys
        )
        check_in_interval("speed_m_s", self.speed_m_s, 0.0, MAX_SPOOFER_SPEED_M_S)
        for name in ("start_enu_m", "goal_enu_m", "centre_enu_m"):
            value = getattr(self, name)
            if value is not None:
                check_finite_vector(name, value, AREA_LIMIT_M, " m")
                if value[2] < 5.0:
                    raise FieldValueError(f"{name}[2]", "a spoofer flies: z >= 5 m")
        if self.waypoints_enu_m is not None:
            _check_points("waypoints_enu_m", self.waypoints_enu_m, 1)
            for i, p in enumerate(self.waypoints_enu_m):
                if p[2] < 5.0:
                    raise FieldValueError(f"waypoints_enu_m[{i}][2]", "a spoofer flies: z >= 5 m")
        if self.radius_m is not None:
            check_in_interval("radius_m", self.radius_m, 0.0, 10_000.0)
        if self.standoff_m is not None:
            check_non_negative("standoff_m", self.standoff_m)

    @property
    def initial_enu_m(self) -> Vec3:
        """Where the spoofer is at sim time 0 (a pursuer starts at ``start_enu_m``, an orbit at
        the east of its circle)."""
        if self.kind in ("line", "pursue"):
            assert self.start_enu_m is not None
            return self.start_enu_m
        if self.kind == "waypoints":
            assert self.waypoints_enu_m is not None
            return self.waypoints_enu_m[0]
        assert self.centre_enu_m is not None and self.radius_m is not None
        c = self.centre_enu_m
        return (c[0] + self.radius_m, c[1], c[2])


@dataclass(frozen=True)
class ClaimConfig:
    """What a spoofer's (or a ghost's) Remote ID says (module docstring)."""

    kind: ClaimKind
    offset_enu_m: Vec3 | None = None
    rate_enu_m_s: Vec3 | None = None
    start_s: float | None = None
    max_offset_m: float | None = None
    target_serial: str | None = None
    delay_s: float | None = None
    at_enu_m: Vec3 | None = None
    waypoints_enu_m: tuple[Vec3, ...] | None = None
    speed_m_s: float | None = None
    loop: bool | None = None

    def __post_init__(self) -> None:
        keys = (
            "offset_enu_m",
            "rate_enu_m_s",
            "start_s",
            "max_offset_m",
            "target_serial",
            "delay_s",
            "at_enu_m",
            "waypoints_enu_m",
            "speed_m_s",
            "loop",
        )
        _check_kind_keys(self, self.kind, _CLAIM_KEYS[self.kind], _CLAIM_OPTIONAL[self.kind], keys)
        if self.offset_enu_m is not None:
            check_finite_vector("offset_enu_m", self.offset_enu_m, 10_000.0, " m")
        if self.rate_enu_m_s is not None:
            check_finite_vector("rate_enu_m_s", self.rate_enu_m_s, 100.0, " m/s")
        if self.at_enu_m is not None:
            check_finite_vector("at_enu_m", self.at_enu_m, AREA_LIMIT_M, " m")
        if self.waypoints_enu_m is not None:
            _check_points("waypoints_enu_m", self.waypoints_enu_m, 1)
        for name in ("start_s", "delay_s"):
            value = getattr(self, name)
            if value is not None:
                check_non_negative(name, value)
        if self.max_offset_m is not None:
            check_in_interval("max_offset_m", self.max_offset_m, 0.0, 10_000.0)
        if self.speed_m_s is not None:
            check_in_interval("speed_m_s", self.speed_m_s, 0.0, 100.0)


@dataclass(frozen=True)
class TxPowerConfig:
    """A transmitter's power: ``fixed`` {dbm} or ``random`` {mean_dbm, sigma_db}, a new
    power drawn for every message."""

    kind: TxPowerKind
    dbm: float | None = None
    mean_dbm: float | None = None
    sigma_db: float | None = None

    def __post_init__(self) -> None:
        required = ("dbm",) if self.kind == "fixed" else ("mean_dbm", "sigma_db")
        _check_kind_keys(self, self.kind, required, (), ("dbm", "mean_dbm", "sigma_db"))
        for name in ("dbm", "mean_dbm"):
            value = getattr(self, name)
            if value is not None and not -30.0 <= value <= 40.0:
                raise FieldValueError(name, f"expected -30..40 dBm, got {value}")
        if self.sigma_db is not None and not 0.0 <= self.sigma_db <= 20.0:
            raise FieldValueError("sigma_db", f"expected 0..20 dB, got {self.sigma_db}")

    @property
    def mean_power_dbm(self) -> float:
        value = self.dbm if self.kind == "fixed" else self.mean_dbm
        assert value is not None
        return value


def _check_intervals(name: str, intervals: tuple[tuple[float, float], ...]) -> None:
    for i, (t0, t1) in enumerate(intervals):
        if not 0.0 <= t0 < t1 <= 86_400.0:
            raise FieldValueError(
                f"{name}[{i}]", f"expected 0 <= start < end <= 86400 s, got {[t0, t1]}"
            )


def silent_at(intervals: tuple[tuple[float, float], ...], now_s: float) -> bool:
    """Inside one of the ``[t0, t1)`` windows."""
    return any(t0 <= now_s < t1 for t0, t1 in intervals)


@dataclass(frozen=True)
class SpooferConfig:
    """One spoofer: a vehicle that flies ``motion``, avoids nobody and broadcasts ``claim``
    (a bystander when the claim is ``truth``: ``role``).

    The top-level ``start_enu_m``, ``goal_enu_m``, ``speed_m_s`` and ``offset_enu_m`` are the
    single-spoofer shorthand for a ``line`` motion and an ``offset`` claim; use either them or
    ``motion`` / ``claim``. ``resolved_motion`` / ``resolved_claim`` give the parts either way.
    """

    serial: str
    start_enu_m: Vec3 | None = None
    goal_enu_m: Vec3 | None = None
    speed_m_s: float = 7.0
    offset_enu_m: Vec3 = (50.0, 50.0, 0.0)
    tx_power_dbm: float | None = None
    motion: MotionConfig | None = None
    claim: ClaimConfig | None = None
    tx_power: TxPowerConfig | None = None
    silent_intervals_s: tuple[tuple[float, float], ...] = ()

    def __post_init__(self) -> None:

        check_cta2063_serial("serial", self.serial)
        if self.motion is None:
            if self.start_enu_m is None or self.goal_enu_m is None:
                raise FieldValueError("motion", "give motion, or start_enu_m and goal_enu_m")
            check_finite_vector("start_enu_m", self.start_enu_m, AREA_LIMIT_M, " m")
            check_finite_vector("goal_enu_m", self.goal_enu_m, AREA_LIMIT_M, " m")
            if not 0.0 < self.speed_m_s <= 8.0:
                raise FieldValueError(
                    "speed_m_s",
                    f"expected 0 < speed <= 8 m/s, got {self.speed_m_s} (a spoofer that "
                    "hovers: goal_enu_m = start_enu_m)",
                )
            if self.start_enu_m[2] < 5.0:
                raise FieldValueError("start_enu_m[2]", "the spoofer starts airborne: z >= 5 m")
        elif self.start_enu_m is not None or self.goal_enu_m is not None:
            raise FieldValueError("start_enu_m", "give motion or start_enu_m/goal_enu_m, not both")
        check_finite_vector("offset_enu_m", self.offset_enu_m, 10_000.0, " m")
        if self.claim is not None and self.offset_enu_m != (50.0, 50.0, 0.0):
            raise FieldValueError("offset_enu_m", "give claim or offset_enu_m, not both")
        if self.tx_power is not None and self.tx_power_dbm is not None:
            raise FieldValueError("tx_power_dbm", "give tx_power or tx_power_dbm, not both")
        _check_intervals("silent_intervals_s", self.silent_intervals_s)

    @property
    def resolved_motion(self) -> MotionConfig:
        if self.motion is not None:
            return self.motion
        return MotionConfig("line", self.speed_m_s, self.start_enu_m, self.goal_enu_m)

    @property
    def resolved_claim(self) -> ClaimConfig:
        if self.claim is not None:
            return self.claim
        return ClaimConfig("offset", offset_enu_m=self.offset_enu_m)

    @property
    def role(self) -> AdversaryRole:
        """``bystander`` when it tells the truth (claim ``truth``), else ``spoofer``."""
        truthful = self.resolved_claim.kind == "truth"
        return AdversaryRole.BYSTANDER if truthful else AdversaryRole.SPOOFER


@dataclass(frozen=True)
class GhostConfig:
    """A transmitter at ``transmitter_enu_m`` (e.g. on the ground) broadcasting Remote ID of an
    aircraft that does not exist, flying ``claim`` (kinds ``waypoints`` or ``fixed``)."""

    serial: str
    transmitter_enu_m: Vec3
    claim: ClaimConfig
    tx_power: TxPowerConfig | None = None
    silent_intervals_s: tuple[tuple[float, float], ...] = ()

    def __post_init__(self) -> None:

        check_cta2063_serial("serial", self.serial)
        check_finite_vector("transmitter_enu_m", self.transmitter_enu_m, AREA_LIMIT_M, " m")
        if self.transmitter_enu_m[2] < 0.0:
            raise FieldValueError("transmitter_enu_m[2]", "above the ground: z >= 0")
        if self.claim.kind not in ("waypoints", "fixed"):
            raise FieldValueError(
                "claim.kind", f"a ghost claims 'waypoints' or 'fixed', got {self.claim.kind!r}"
            )
        _check_intervals("silent_intervals_s", self.silent_intervals_s)
