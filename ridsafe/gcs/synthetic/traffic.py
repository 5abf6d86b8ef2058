"""Seeded synthetic observed claims for the GCS estimation pipeline, heard as the sim hears.

Scene: ``n_receivers`` benign aircraft over 1 km x 1 km and one spoofer on a straight line
(~7 m/s, ~60 m) broadcasting its true position plus a constant offset. Every aircraft
broadcasts at 1 Hz with its own random phase; every other aircraft hears it through the
path-loss model the sim radio uses (``ridsafe.common.pathloss.received_power_dbm``, at
2400 MHz) plus shadowing::

    RSSI = Pt - 20 log10(max(d_m, 1)) - 40.0442 + N(0, sigma^2),   heard if >= sensitivity

Benign aircraft either fly between random waypoints at 30-100 m and up to 8 m/s
(``start="airborne"``), or start on the ground at the default scenario's three depots, climb
to a cruise height and fly to a delivery site (``start="depots"``, like the lockstep runs).
``parked_receivers_enu_m`` adds aircraft standing still at those points (on the ground, waiting
to take off), after the benign ones. A transmission closes at the first GCS cycle at least
``close_lag_s`` after it (the GCS shell's grouping window is 0.3 s). Optional imperfections:
reported receiver positions with noise, claimed altitudes truncated to the F3411 0.5 m step.

``evaluate.run_pipeline`` drives an ``EstimationPipeline`` over the traffic and measures it.
Used by the GCS tests and by ``bench/bench_gcs.py``; the draws come from one generator per
scene seed, so a scene is the same traffic on every machine.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.pathloss import received_power_dbm
from ridsafe.gcs.pipeline_api import ObservedClaim, readonly

FloatArray = NDArray[np.float64]

SPOOFER_ID = "RSAF800000666"
DEPOTS_ENU_M = np.array([[-350.0, -350.0, 0.0], [350.0, -350.0, 0.0], [0.0, 380.0, 0.0]])
CYCLE_S = 0.25


def benign_id(i: int) -> str:
    return f"RSAF8000{i + 1:05d}"


@dataclass(frozen=True)
class Scene:
    """What to generate (module docstring): distances in m, powers in dBm, times in s."""

    seed: int = 0
    n_receivers: int = 8
    duration_s: float = 120.0
    sigma_db: float = 1.0
    tx_power_dbm: float = 20.0
    spoofer_tx_power_dbm: float = 20.0
    spoofer_offset_enu_m: tuple[float, float, float] = (50.0, 50.0, 0.0)
    spoofer_speed_m_s: float = 7.0
    spoofer_alt_m: float = 60.0
    #: Vertical speed of the spoofer (m/s; 0: level flight as in the default scenario).
    spoofer_climb_m_s: float = 0.0
    with_spoofer: bool = True
    start: Literal["airborne", "depots"] = "airborne"
    receiver_alt_m: tuple[float, float] = (30.0, 100.0)
    max_speed_m_s: float = 8.0
    half_width_m: float = 500.0
    sensitivity_dbm: float = -95.0
    rx_position_sigma_m: float = 0.0
    quantise_claimed_alt: bool = False
    close_lag_s: float = 0.3
    #: Every aircraft broadcasts at the same phase (worst case for a GCS cycle's load).
    aligned_phases: bool = False
    #: Aircraft that stand still at these points (e.g. parked on a pad), after the others.
    parked_receivers_enu_m: tuple[tuple[float, float, float], ...] = ()


@dataclass(frozen=True, eq=False)
class Path:
    """Piecewise-linear trajectory: knot times (m,) and positions (m, 3)."""

    t_s: FloatArray
    p_enu_m: FloatArray

    def at(self, t_s: FloatArray | float) -> FloatArray:
        t = np.atleast_1d(np.asarray(t_s, dtype=np.float64))
        out = np.column_stack([np.interp(t, self.t_s, self.p_enu_m[:, k]) for k in range(3)])
        return out


def _waypoint_path(rng: np.random.Generator, scene: Scene) -> Path:
    lo, hi = scene.receiver_alt_m
    h = scene.half_width_m
    p = np.array([*rng.uniform(-h, h, 2), rng.uniform(lo, hi)])
    times, points = [0.0], [p]
    while times[-1] < scene.duration_s + 2.0:
        q = np.array([*rng.uniform(-h, h, 2), rng.uniform(lo, hi)])
        speed = rng.uniform(0.5, 1.0) * scene.max_speed_m_s
        times.append(times[-1] + float(np.linalg.norm(q - points[-1])) / speed)
        points.append(q)
    return Path(np.array(times), np.array(points))


def _depot_path(rng: np.random.Generator, scene: Scene) -> Path:
    lo, hi = scene.receiver_alt_m
    h = scene.half_width_m
    depot = DEPOTS_ENU_M[rng.integers(len(DEPOTS_ENU_M))] + np.r_[rng.uniform(-5, 5, 2), 0.0]
    cruise = rng.uniform(lo, hi)
    goal = np.array([*rng.uniform(-0.9 * h, 0.9 * h, 2), cruise])
    t_off = rng.uniform(0.0, 3.0)
    t_top = t_off + cruise / 2.5
    above = np.r_[depot[:2], cruise]
    t_goal = t_top + float(np.linalg.norm(goal - above)) / scene.max_speed_m_s
    times = np.array([0.0, t_off, t_top, t_goal, max(t_goal, scene.duration_s) + 2.0])
    return Path(times, np.array([depot, depot, above, goal, goal]))


def _spoofer_path(rng: np.random.Generator, scene: Scene) -> Path:
    h = scene.half_width_m
    angle = rng.uniform(0.0, 2.0 * math.pi)
    direction = np.array([math.cos(angle), math.sin(angle), 0.0])
    lateral = np.array([-direction[1], direction[0], 0.0]) * rng.uniform(-0.3, 0.3) * h
    start = -0.95 * h * direction + lateral + np.r_[0.0, 0.0, scene.spoofer_alt_m]
    end_t = scene.duration_s + 2.0
    end = start + direction * scene.spoofer_speed_m_s * end_t
    end[2] += scene.spoofer_climb_m_s * end_t
    return Path(np.array([0.0, end_t]), np.vstack((start, end)))


@dataclass(frozen=True, eq=False)
class Traffic:
    scene: Scene
    paths: tuple[Path, ...]  # benign 0..n-1, then the spoofer
    ids: tuple[str, ...]
    cycles: dict[float, list[ObservedClaim]] = field(default_factory=dict)
    #: Where the spoofer's broadcasts claim it is (None: its true position plus the offset).
    claim_path: Path | None = None

    @property
    def spoofer_path(self) -> Path:
        return self.paths[-1]


def make_traffic(
    scene: Scene, spoofer_path: Path | None = None, claim_path: Path | None = None
) -> Traffic:
    """Every observed claim of the scene, grouped by the GCS cycle that delivers it.

    ``spoofer_path``: the spoofer flies it instead of its straight line (a manoeuvring
    spoofer, or a ghost's radio standing still); the line is still drawn, so the benign
    traffic and every phase stay the same. ``claim_path``: where its broadcasts claim it is.
    """
    rng = np.random.default_rng(scene.seed)
    path_rng, radio_rng = rng.spawn(2)
    make = _waypoint_path if scene.start == "airborne" else _depot_path
    paths = [make(path_rng, scene) for _ in range(scene.n_receivers)]
    end_s = scene.duration_s + 2.0
    for point in scene.parked_receivers_enu_m:
        paths.append(Path(np.array([0.0, end_s]), np.array([point, point], dtype=np.float64)))
    ids = [benign_id(i) for i in range(len(paths))]
    powers = [scene.tx_power_dbm] * len(paths)
    if scene.with_spoofer:
        line = _spoofer_path(path_rng, scene)
        paths.append(line if spoofer_path is None else spoofer_path)
        ids.append(SPOOFER_ID)
        powers.append(scene.spoofer_tx_power_dbm)
    phases = path_rng.uniform(0.0, 1.0, len(paths))
    if scene.aligned_phases:
        phases[:] = phases[0]
    events = sorted(
        (phase + k, i)
        for i, phase in enumerate(phases)
        for k in range(int(scene.duration_s - phase) + 1)
    )
    traffic = Traffic(scene, tuple(paths), tuple(ids), claim_path=claim_path)
    for t, sender in events:
        claim = _observed_claim(traffic, t, sender, powers[sender], radio_rng)
        if claim is None:
            continue
        cycle = math.ceil((t + scene.close_lag_s) / CYCLE_S - 1e-9) * CYCLE_S
        traffic.cycles.setdefault(round(cycle, 6), []).append(claim)
    return traffic


def _observed_claim(
    traffic: Traffic, t: float, sender: int, pt: float, rng: np.random.Generator
) -> ObservedClaim | None:
    scene = traffic.scene
    n = len(traffic.paths)
    p = np.vstack([path.at(t) for path in traffic.paths])
    d = np.linalg.norm(p - p[sender], axis=1)
    rssi = received_power_dbm(pt, d)
    rssi = rssi + rng.normal(0.0, scene.sigma_db, n)
    heard = rssi >= scene.sensitivity_dbm
    heard[sender] = False
    rx_noise = rng.normal(0.0, scene.rx_position_sigma_m, (n, 3))
    if not np.any(heard):
        return None
    claimed = p[sender].copy()
    if scene.with_spoofer and sender == n - 1:
        if traffic.claim_path is None:
            claimed += np.asarray(scene.spoofer_offset_enu_m)
        else:
            claimed = traffic.claim_path.at(t)[0]
    if scene.quantise_claimed_alt:
        claimed[2] = math.floor(claimed[2] / 0.5) * 0.5
    idx = np.flatnonzero(heard)
    return ObservedClaim(
        uas_id=traffic.ids[sender],
        rid_timestamp_s=t,
        claimed_p_enu_m=readonly(claimed),
        claimed_v_enu_m_s=None,
        rx_sysid=np.asarray(idx + 1, dtype=np.int64),
        rx_p_enu_m=readonly(p[idx] + rx_noise[idx]),
        rx_t_s=readonly(np.full(idx.shape[0], t)),
        rssi_dbm=readonly(rssi[idx]),
    )
