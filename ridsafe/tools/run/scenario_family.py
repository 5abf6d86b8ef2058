"""The paper's package-delivery scenario family, drawn per seed.

1 km x 1 km (ENU about the origin, x and y in [-500, 500] m); three depots; benign aircraft
start at the depots in turn (aircraft k at depot k mod 3), each depot launching one aircraft
every ``launch_interval_s`` (faster when that would not fit in ``launch_window_s``) from pads
``pad_spacing_m`` apart inside the area, so departing aircraft do not start inside each
other's NMAC radius (``family_launches``: the schedule, the pads, and the refusal of an N that
cannot be drawn); each delivery site is drawn uniformly in the area, and the launch takes the
free pad facing it (``pad_choice``), with the site between ``min_trip_m`` and ``max_trip_m``
from that pad and, for a late launch, near enough to it that a nominal flight
(``nominal_takeoff_s``, then straight at ``nominal_speed_m_s``) arrives by
``delivery_deadline_s`` (never binding for launches up to 20 s); cruise altitudes are drawn
from ``cruise_alts_m``. ``pad_choice: in_turn`` draws the scenarios of the reports flown
before the pads faced the deliveries (pads in ring order, trips measured from the depot). One
spoofer crosses the area on a straight line near its centre at constant speed and cruise
altitude, broadcasting a constant offset.

More aircraft than ``tile_capacity`` (when set) get more ground: the family is drawn on k x k
copies of the area with their depots (``FamilyConfig.sized``), the cadence, pads, trips and
deadline as above. Without it the area stays and only the cadence adapts (``family_launches``),
so 64 aircraft fly four times the paper's densest traffic (``docs/results/dense_traffic.md``).
The one spoofer's line then starts at the larger area's edge (at 2 km x 2 km it does not reach
the centre within 120 s); ``adversaries.spoofer_count`` adds more.

The spoofer aims at the traffic, as an adversary would: ``spoofer_candidate_lines`` lines are
drawn, and it flies the one that the benign aircraft's nominal flights (straight from pad to
delivery at ``nominal_speed_m_s``, climbing at ``nominal_climb_m_s``, nobody avoiding anybody)
bring within ``nmac_radius_m`` of it most often. A random line through the centre meets few
deliveries: trust-RID then suffers fewer benign-spoofer NMACs than the paper reports, and beating
the paper on such a scenario would mean nothing. With one candidate the line is purely random.

Matched seeds: the aircraft are drawn from ``rng.stream(seed, "scenario")`` with a fixed
number of draws per aircraft, the spoofer's candidate lines from a stream of their own, so the
same seed gives the same depots, deliveries and spoofer for both planners, and aircraft k of a
16-aircraft scenario is aircraft k of the 8-aircraft one (the candidate lines are the same too;
which one the spoofer flies depends on the traffic). The aim looks ``aim_horizon_s`` ahead
(not the run's duration), so ``--duration`` never changes which line is drawn.

``adversaries`` (``family_adversaries.AdversaryDraw``) draws more spoofers, other motion and
claim kinds, random power, ghosts and honest bystanders per seed; its default is the one
aimed-line offset spoofer above, given as the scenario's ``spoofer`` shorthand.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ridsafe.common import rng
from ridsafe.common.errors import FieldValueError
from ridsafe.common.scenario import (
    AircraftConfig,
    Scenario,
    SpooferConfig,
    Vec3,
    cta2063_serial,
)
from ridsafe.tools.run.family_adversaries import (
    AdversaryDraw,
    draw_bystander,
    draw_ghost,
    draw_spoofer,
)
from ridsafe.tools.run.family_launches import (
    DepotPads,
    Launch,
    LaunchRules,
    PadChoice,
    launch_schedule,
)

SERIAL_MAKER = "RSAF"


@dataclass(frozen=True)
class FamilyConfig:
    """How a scenario of the family is drawn (YAML ``family:`` section)."""

    half_width_m: float = 500.0
    depots_enu_m: tuple[Vec3, ...] = (
        (-380.0, -380.0, 0.0),
        (380.0, -380.0, 0.0),
        (0.0, 400.0, 0.0),
    )
    launch_interval_s: float = 4.0  # the longest interval between launches of a depot
    launch_window_s: float = 40.0  # every launch at or before this (the cadence adapts)
    min_launch_interval_s: float = 1.0  # a denser family is refused
    # Pads of one depot: the first at the depot, the next on rings around it (6 q pads on
    # ring q, radius q * pad_spacing_m), so pads are >= pad_spacing_m apart: above the
    # 50 m NMAC radius, aircraft climbing from neighbouring pads do not count as an NMAC.
    pad_spacing_m: float = 55.0
    max_pad_rings: int = 2  # a depot's pads lie within max_pad_rings * pad_spacing_m
    pad_margin_m: float = 5.0  # pads at least this far inside the area's edge
    pad_reuse_s: float = 15.0  # a pad launches again no sooner than this
    # Which pad a launch takes (family_launches): the free pad facing its delivery, so the
    # departure leaves the depot behind it; in_turn (the rings in order, trips measured from
    # the depot) draws the scenarios of the reports flown before it.
    pad_choice: PadChoice = PadChoice.TOWARD_DELIVERY
    min_trip_m: float = 300.0
    max_trip_m: float = 550.0  # a delivery, with detours and the landing, fits in 120 s
    # A nominal flight from the pad arrives by this time (caps the trips of late launches;
    # the run's duration is not used, so --duration never changes the draw). 93 s: the latest
    # nominal arrival the paper's densities draw (16 aircraft: a launch at 20 s, 4 s take-off,
    # max_trip_m at 8 m/s, 92.75 s), so a denser family's late launches get no less time for
    # traffic than the paper's. A real delivery takes longer than the nominal flight: a median
    # 11 s from take-off (the climb, the braking, the approach; the paper matrix's 4-aircraft
    # runs), so the latest launches arrive unhindered at about 104 s of 120.
    delivery_deadline_s: float = 93.0
    cruise_alts_m: tuple[float, ...] = (50.0, 60.0, 70.0)
    # False: each aircraft's cruise altitude drawn from cruise_alts_m. True: by the heading of
    # its trip, cruise_alts_m[k] for the k-th of len(cruise_alts_m) equal sectors (from east,
    # counter-clockwise), as layered-airspace concepts do (Sunil et al., "Metropolis: Relating
    # Airspace Structure and Capacity for Extreme Traffic Densities", ATM Seminar 2015): within
    # a layer aircraft fly roughly the same way, so head-on and crossing conflicts move to the
    # climbs and descents. The draws are the same either way.
    cruise_alt_by_heading: bool = False
    spoofer_speed_m_s: float = 7.0
    spoofer_alt_m: float = 60.0
    spoofer_offset_enu_m: Vec3 = (50.0, 50.0, 0.0)
    spoofer_through_radius_m: float = 30.0  # its line passes this close to the centre
    spoofer_candidate_lines: int = 32  # it flies the one the nominal traffic meets most
    nominal_speed_m_s: float = 8.0  # nominal benign flight, only to aim the spoofer
    nominal_climb_m_s: float = 2.5
    nominal_takeoff_s: float = 4.0  # from departure to leaving the pad
    nmac_radius_m: float = 50.0
    aim_horizon_s: float = 120.0  # how far ahead the spoofer's aim looks (not the duration)
    adversaries: AdversaryDraw = field(default_factory=AdversaryDraw)
    # Ours: more aircraft on more ground. None: the area and depots as given, and only the
    # launch cadence adapts to N. A number C: a scenario of N > C aircraft is drawn on k x k
    # copies of the area side by side, k = ceil(sqrt(ceil(N / C))), each copy with the given
    # depots (sized()), so no copy holds more than C aircraft on average and each aircraft
    # meets about the traffic it would among C on the original area. configs/paper.yaml: 16,
    # the paper's densest (64 aircraft: 2 km x 2 km, 12 depots).
    tile_capacity: int | None = None

    def __post_init__(self) -> None:
        if not self.depots_enu_m:
            raise FieldValueError("depots_enu_m", "need at least one depot")
        if not self.cruise_alts_m:
            raise FieldValueError("cruise_alts_m", "need at least one cruise altitude")
        if not 0.0 < self.min_trip_m < self.max_trip_m:
            raise FieldValueError("min_trip_m", "expected 0 < min_trip_m < max_trip_m")
        if self.spoofer_candidate_lines < 1:
            raise FieldValueError("spoofer_candidate_lines", "need at least one line")
        if self.nominal_speed_m_s <= 0.0 or self.nominal_climb_m_s <= 0.0:
            raise FieldValueError("nominal_speed_m_s", "nominal speeds must be > 0")
        if not 0.0 < self.min_launch_interval_s <= self.launch_interval_s:
            raise FieldValueError(
                "min_launch_interval_s", "expected 0 < min_launch_interval_s <= launch_interval_s"
            )
        if self.tile_capacity is not None and self.tile_capacity < 1:
            raise FieldValueError(
                "tile_capacity", f"expected >= 1 aircraft (or null), got {self.tile_capacity}"
            )
        if self.max_pad_rings < 0:
            raise FieldValueError("max_pad_rings", f"expected >= 0, got {self.max_pad_rings}")
        latest_trip_m = self.nominal_speed_m_s * (
            self.delivery_deadline_s - self.launch_window_s - self.nominal_takeoff_s
        )
        if latest_trip_m < self.min_trip_m:
            raise FieldValueError(
                "delivery_deadline_s",
                f"an aircraft launched at launch_window_s={self.launch_window_s:g} s could fly "
                f"only {latest_trip_m:.0f} m by then, less than min_trip_m={self.min_trip_m:g}",
            )

    def tiles_per_side(self, n_aircraft: int) -> int:
        """k: a scenario of ``n_aircraft`` is drawn on k x k copies of the area."""
        if self.tile_capacity is None or n_aircraft <= self.tile_capacity:
            return 1
        return math.ceil(math.sqrt(math.ceil(n_aircraft / self.tile_capacity)))

    def sized(self, n_aircraft: int) -> FamilyConfig:
        """The family that draws ``n_aircraft``: this one, or (``tile_capacity``) one on k x k
        copies of the area, centred where this one is. Its depots are the given ones, each in
        every copy in turn (copies from the south-west, row by row), so aircraft j departs
        from copy j mod k^2 and the copies' shares differ by one aircraft at most."""
        k = self.tiles_per_side(n_aircraft)
        if k == 1:
            return self
        centres_m = [(2 * i - (k - 1)) * self.half_width_m for i in range(k)]
        depots = tuple(
            (e + de, n + dn, u)
            for (e, n, u) in self.depots_enu_m
            for dn in centres_m
            for de in centres_m
        )
        return dataclasses.replace(
            self, half_width_m=k * self.half_width_m, depots_enu_m=depots, tile_capacity=None
        )

    @property
    def launch_rules(self) -> LaunchRules:
        return LaunchRules(
            self.half_width_m,
            self.depots_enu_m,
            self.launch_interval_s,
            self.launch_window_s,
            self.min_launch_interval_s,
            self.pad_spacing_m,
            self.max_pad_rings,
            self.pad_margin_m,
            self.pad_reuse_s,
        )


def generate(base: Scenario, n_aircraft: int, seed: int, family: FamilyConfig) -> Scenario:
    """Scenario ``seed`` of the family with ``n_aircraft`` benign aircraft (and a spoofer)."""
    family = family.sized(n_aircraft)
    launches = launch_schedule(n_aircraft, family.launch_rules)
    draw = rng.stream(seed, "scenario")
    depots: list[DepotPads] | None = None
    if family.pad_choice is PadChoice.TOWARD_DELIVERY:
        depots = [DepotPads(d, family.launch_rules) for d in family.depots_enu_m]
    aircraft = tuple(
        _aircraft(k, launch, draw, family, None if depots is None else depots[launch.depot_index])
        for k, launch in enumerate(launches)
    )
    wanted = family.adversaries.resolved()
    name = f"family-n{n_aircraft}-s{seed}"
    if wanted.is_default:
        spoofer = _aimed_line(aircraft, seed, "scenario/spoofer", family)
        if wanted.tx_power_dbm is not None:
            spoofer = dataclasses.replace(spoofer, tx_power_dbm=wanted.tx_power_dbm)
        return dataclasses.replace(
            base, aircraft=aircraft, spoofer=spoofer, spoofers=(), ghosts=(), seed=seed, name=name
        )
    spoofers = tuple(
        draw_spoofer(
            k,
            seed,
            _aimed_line(
                aircraft, seed, "scenario/spoofer" if k == 0 else f"scenario/spoofer/{k}", family
            ),
            aircraft,
            family.depots_enu_m,
            family.half_width_m,
            family.spoofer_alt_m,
            base.radio.tx_power_dbm,
            wanted,
        )
        for k in range(wanted.spoofer_count)
    )
    ghosts = tuple(
        draw_ghost(k, seed, family.half_width_m, family.spoofer_alt_m, wanted)
        for k in range(wanted.ghost_count)
    )
    bystanders = tuple(
        draw_bystander(k, seed, family.half_width_m, family.spoofer_alt_m, family.spoofer_speed_m_s)
        for k in range(wanted.bystander_count)
    )
    return dataclasses.replace(
        base,
        aircraft=aircraft,
        spoofer=None,
        spoofers=spoofers + bystanders,
        ghosts=ghosts,
        seed=seed,
        name=name,
    )


#: The time step (s) of the nominal flights a spoofer's line is aimed at.
AIM_STEP_S = 0.5


def _aimed_line(
    aircraft: tuple[AircraftConfig, ...], seed: int, stream: str, family: FamilyConfig
) -> SpooferConfig:
    """Of ``spoofer_candidate_lines`` lines drawn from ``stream``, the one the nominal traffic
    meets most (the first of equals)."""
    spoofer_draw = rng.stream(seed, stream)
    candidates = [_spoofer(spoofer_draw, family) for _ in range(family.spoofer_candidate_lines)]
    t_s = np.arange(0.0, family.aim_horizon_s, AIM_STEP_S)
    flights_enu_m = _nominal_flights(aircraft, t_s, family)
    met = [_nominal_encounters(flights_enu_m, t_s, c, family) for c in candidates]
    return candidates[int(np.argmax(met))]


def _nominal_encounters(
    flights_enu_m: np.ndarray, t_s: np.ndarray, spoofer: SpooferConfig, family: FamilyConfig
) -> int:
    """How many times the nominal benign flights (``flights_enu_m : (A, T, 3)`` at times
    ``t_s``, :func:`_nominal_flights`) come within the NMAC radius of the spoofer."""
    assert spoofer.start_enu_m is not None and spoofer.goal_enu_m is not None
    s0, s1 = np.array(spoofer.start_enu_m), np.array(spoofer.goal_enu_m)
    length_m = float(np.linalg.norm(s1 - s0))
    spoofer_enu = s0 + np.outer(np.minimum(t_s * spoofer.speed_m_s, length_m), (s1 - s0) / length_m)
    distance_m = np.linalg.norm(flights_enu_m - spoofer_enu, axis=2)
    inside = distance_m < family.nmac_radius_m
    entries = np.count_nonzero(inside[:, 1:] & ~inside[:, :-1])
    return int(np.count_nonzero(inside[:, 0])) + int(entries)


def _nominal_flights(
    aircraft: Sequence[AircraftConfig], t_s: np.ndarray, family: FamilyConfig
) -> np.ndarray:
    """ENU positions (m), ``(A, T, 3)``, of each aircraft's straight pad-to-delivery flight
    nobody deflects, at times ``t_s``."""
    start = np.array([a.start_enu_m for a in aircraft], dtype=np.float64).reshape(-1, 3)
    goal = np.array([a.goal_enu_m for a in aircraft], dtype=np.float64).reshape(-1, 3)
    departure_s = np.array([a.departure_s for a in aircraft], dtype=np.float64)
    cruise_m = np.array([a.cruise_alt_m for a in aircraft], dtype=np.float64)[:, None]
    trip_m = np.maximum(np.hypot(goal[:, 0] - start[:, 0], goal[:, 1] - start[:, 1]), 1e-9)
    flying_s = np.maximum(t_s - departure_s[:, None] - family.nominal_takeoff_s, 0.0)
    along_m = np.minimum(flying_s * family.nominal_speed_m_s, trip_m[:, None])
    heading = (goal - start)[:, :2] / trip_m[:, None]
    xy = start[:, None, :2] + along_m[:, :, None] * heading[:, None, :]
    climb_m = np.minimum(flying_s * family.nominal_climb_m_s, cruise_m)
    descent_m = np.maximum(flying_s - (trip_m / family.nominal_speed_m_s)[:, None], 0.0) * (
        family.nominal_climb_m_s
    )
    up_m = np.maximum(np.minimum(climb_m, cruise_m - descent_m), 0.0)
    return np.concatenate([xy, up_m[:, :, None]], axis=2)


def _aircraft(
    k: int,
    launch: Launch,
    draw: np.random.Generator,
    family: FamilyConfig,
    depot_pads: DepotPads | None,
) -> AircraftConfig:
    """Aircraft ``k``: its delivery site, and its pad (``depot_pads``: the free pad facing the
    site, and the trip measured from it; None: the launch's pad in turn, the trip from the
    depot)."""
    depot = np.array(family.depots_enu_m[launch.depot_index])
    # A fixed number of draws per aircraft keeps seeds matched across densities.
    u = draw.random(65)
    flying_s = family.delivery_deadline_s - launch.departure_s - family.nominal_takeoff_s
    max_from_pad_m = flying_s * family.nominal_speed_m_s

    def pad_for(site: np.ndarray) -> Vec3:
        if depot_pads is None:
            return launch.pad_enu_m
        return depot_pads.facing(site.tolist(), launch.departure_s)

    trip_from_pad = depot_pads is not None
    goal, pad_enu = _delivery_site(u[:-1], depot, pad_for, trip_from_pad, max_from_pad_m, family)
    if depot_pads is not None:
        depot_pads.take(pad_enu, launch.departure_s)
    pad = np.array(pad_enu)
    alt = family.cruise_alts_m[int(u[-1] * len(family.cruise_alts_m))]
    if family.cruise_alt_by_heading:
        alt = family.cruise_alts_m[_heading_sector(goal - pad, len(family.cruise_alts_m))]
    return AircraftConfig(
        serial=cta2063_serial(SERIAL_MAKER, f"{k + 1:08d}"),
        start_enu_m=pad_enu,
        goal_enu_m=_vec(goal),
        cruise_alt_m=alt,
        departure_s=launch.departure_s,
    )


def _heading_sector(trip_enu_m: np.ndarray, sectors: int) -> int:
    """Which of ``sectors`` equal heading sectors (from east, counter-clockwise) a trip
    lies in."""
    angle = math.atan2(float(trip_enu_m[1]), float(trip_enu_m[0])) % (2.0 * math.pi)
    return min(int(angle / (2.0 * math.pi) * sectors), sectors - 1)


def _delivery_site(
    uniforms: np.ndarray,
    depot: np.ndarray,
    pad_for: Callable[[np.ndarray], Vec3],
    trip_from_pad: bool,
    max_from_pad_m: float,
    family: FamilyConfig,
) -> tuple[np.ndarray, Vec3]:
    """Rejection-sample a site ``min_trip_m``..``max_trip_m`` from the pad
    (``trip_from_pad``) or the depot, and at most ``max_from_pad_m`` from the pad, where
    ``pad_for(site)`` is the pad that launches toward it; the site and its pad
    (deterministic given uniforms)."""
    w = family.half_width_m * 0.9
    for ux, uy in uniforms.reshape(-1, 2):
        site = np.array([(2 * ux - 1) * w, (2 * uy - 1) * w, 0.0])
        pad = pad_for(site)
        from_pad_m = math.hypot(site[0] - pad[0], site[1] - pad[1])
        trip_m = from_pad_m if trip_from_pad else float(np.hypot(*(site - depot)[:2]))
        if family.min_trip_m <= trip_m <= family.max_trip_m and from_pad_m <= max_from_pad_m:
            return site, pad
    toward_centre = -depot / max(float(np.linalg.norm(depot)), 1e-9)
    trip_m = min(0.5 * (family.min_trip_m + family.max_trip_m), max_from_pad_m)
    site = depot + toward_centre * trip_m
    return site, pad_for(site)


def _spoofer(draw: np.random.Generator, family: FamilyConfig) -> SpooferConfig:
    """A straight line from one edge to the opposite one, passing near the centre."""
    heading = draw.uniform(0.0, 2 * math.pi)
    offset = draw.uniform(-1.0, 1.0) * family.spoofer_through_radius_m
    direction = np.array([math.cos(heading), math.sin(heading), 0.0])
    normal = np.array([-direction[1], direction[0], 0.0])
    through = offset * normal + np.array([0.0, 0.0, family.spoofer_alt_m])
    half_length = family.half_width_m * 1.05
    start = through - half_length * direction
    goal = through + half_length * direction
    return SpooferConfig(
        serial=cta2063_serial(SERIAL_MAKER, "00000666"),
        start_enu_m=_vec(start),
        goal_enu_m=_vec(goal),
        speed_m_s=family.spoofer_speed_m_s,
        offset_enu_m=family.spoofer_offset_enu_m,
    )


def _vec(p: np.ndarray) -> Vec3:
    return (round(float(p[0]), 3), round(float(p[1]), 3), round(float(p[2]), 3))
