"""Seeded synthetic Remote ID traffic for the GCS estimation pipeline, matching the sim's radio.

Scene: ``n_receivers`` benign aircraft over 1 km x 1 km and one spoofer on a straight line
(~7 m/s, ~60 m) broadcasting its true position plus a constant offset. Every aircraft
broadcasts at 1 Hz with its own random phase; every other aircraft hears it with the sim
radio's model (``ridsafe/sim_backend/radio.py``)::

    RSSI = Pt - 20 log10(max(d_m, 1)) - 40.0442 + N(0, sigma^2),   heard if >= sensitivity

Benign aircraft either fly between random waypoints at 30-100 m and up to 8 m/s
(``start="airborne"``), or start on the ground at the default scenario's three depots, climb
to a cruise height and fly to a delivery site (``start="depots"``, like the lockstep runs).
A transmission closes at the first GCS cycle at least ``close_lag_s`` after it (the GCS
shell's grouping window is 0.3 s). Optional imperfections: reported receiver positions with
noise, claimed altitudes truncated to the F3411 0.5 m step.

``run_pipeline`` drives an ``EstimationPipeline`` over a scene and measures what the issue
asks: detection delay, false alerts on benign aircraft, containment and RMSE after the alert,
compute per cycle.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.messages import AlertState, RidsafeDetector
from ridsafe.common.pathloss import LOSS_AT_1M_2400MHZ_DB
from ridsafe.gcs.pipeline import EstimationPipeline
from ridsafe.gcs.pipeline_api import CycleOutput, DetectorResult, Transmission, readonly
from ridsafe.gcs.pipeline_config import PipelineConfig

FloatArray = NDArray[np.float64]

SPOOFER_ID = "RSAF800000666"
DEPOTS_ENU_M = np.array([[-350.0, -350.0, 0.0], [350.0, -350.0, 0.0], [0.0, 380.0, 0.0]])
CYCLE_S = 0.25


def benign_id(i: int) -> str:
    return f"RSAF8000{i + 1:05d}"


@dataclass(frozen=True)
class Scene:
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
    cycles: dict[float, list[Transmission]] = field(default_factory=dict)

    @property
    def spoofer_path(self) -> Path:
        return self.paths[-1]


def make_traffic(scene: Scene) -> Traffic:
    """Every transmission of the scene, grouped by the GCS cycle that delivers it."""
    rng = np.random.default_rng(scene.seed)
    path_rng, radio_rng = rng.spawn(2)
    make = _waypoint_path if scene.start == "airborne" else _depot_path
    paths = [make(path_rng, scene) for _ in range(scene.n_receivers)]
    ids = [benign_id(i) for i in range(scene.n_receivers)]
    powers = [scene.tx_power_dbm] * scene.n_receivers
    if scene.with_spoofer:
        paths.append(_spoofer_path(path_rng, scene))
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
    traffic = Traffic(scene, tuple(paths), tuple(ids))
    for t, sender in events:
        tx = _transmission(traffic, t, sender, powers[sender], radio_rng)
        if tx is None:
            continue
        cycle = math.ceil((t + scene.close_lag_s) / CYCLE_S - 1e-9) * CYCLE_S
        traffic.cycles.setdefault(round(cycle, 6), []).append(tx)
    return traffic


def _transmission(
    traffic: Traffic, t: float, sender: int, pt: float, rng: np.random.Generator
) -> Transmission | None:
    scene = traffic.scene
    n = len(traffic.paths)
    p = np.vstack([path.at(t) for path in traffic.paths])
    d = np.linalg.norm(p - p[sender], axis=1)
    rssi = pt - 20.0 * np.log10(np.maximum(d, 1.0)) - LOSS_AT_1M_2400MHZ_DB
    rssi = rssi + rng.normal(0.0, scene.sigma_db, n)
    heard = rssi >= scene.sensitivity_dbm
    heard[sender] = False
    rx_noise = rng.normal(0.0, scene.rx_position_sigma_m, (n, 3))
    if not np.any(heard):
        return None
    claimed = p[sender].copy()
    if scene.with_spoofer and sender == n - 1:
        claimed += np.asarray(scene.spoofer_offset_enu_m)
    if scene.quantise_claimed_alt:
        claimed[2] = math.floor(claimed[2] / 0.5) * 0.5
    idx = np.flatnonzero(heard)
    return Transmission(
        uas_id=traffic.ids[sender],
        rid_timestamp_s=t,
        claimed_p_enu_m=readonly(claimed),
        claimed_v_enu_m_s=None,
        rx_sysid=np.asarray(idx + 1, dtype=np.int64),
        rx_p_enu_m=readonly(p[idx] + rx_noise[idx]),
        rx_t_s=readonly(np.full(idx.shape[0], t)),
        rssi_dbm=readonly(rssi[idx]),
    )


@dataclass
class RunMetrics:
    """What one run measured (times in s, distances in m)."""

    first_heard_by_4_s: float = math.nan
    alert_s: float = math.nan
    alert_detector: RidsafeDetector | None = None
    first_region_s: float = math.nan
    false_alerts: int = 0
    containment: list[bool] = field(default_factory=list)
    errors_m: list[float] = field(default_factory=list)
    errors_h_m: list[float] = field(default_factory=list)
    nees: list[float] = field(default_factory=list)
    compute_s: list[float] = field(default_factory=list)
    results: list[tuple[bool, DetectorResult]] = field(default_factory=list)

    @property
    def delay_s(self) -> float:
        return self.alert_s - self.first_heard_by_4_s

    @property
    def containment_rate(self) -> float:
        return float(np.mean(self.containment)) if self.containment else math.nan

    @property
    def rmse_m(self) -> float:
        return float(np.sqrt(np.mean(np.square(self.errors_m)))) if self.errors_m else math.nan

    @property
    def rmse_h_m(self) -> float:
        e = self.errors_h_m
        return float(np.sqrt(np.mean(np.square(e)))) if e else math.nan


def run_pipeline(
    traffic: Traffic,
    config: PipelineConfig,
    keep_results: bool = False,
    on_cycle: Callable[[float, CycleOutput], None] | None = None,
) -> RunMetrics:
    """Drive a fresh pipeline over ``traffic`` cycle by cycle and measure it."""
    pipeline = EstimationPipeline(config)
    metrics = RunMetrics()
    n_cycles = round(traffic.scene.duration_s / CYCLE_S)
    for k in range(1, n_cycles + 1):
        now = round(k * CYCLE_S, 6)
        txs = traffic.cycles.get(now, [])
        for tx in txs:
            if (
                tx.uas_id == SPOOFER_ID
                and tx.n_receivers >= 4
                and math.isnan(metrics.first_heard_by_4_s)
            ):
                metrics.first_heard_by_4_s = tx.t_s
        out = pipeline.step(now, txs)
        metrics.compute_s.append(pipeline.compute_s[-1])
        _score(traffic, now, out, metrics, keep_results)
        if on_cycle is not None:
            on_cycle(now, out)
    return metrics


def _score(traffic: Traffic, now: float, out: CycleOutput, metrics: RunMetrics, keep: bool) -> None:
    for change in out.alert_changes:
        if change.state is not AlertState.RAISED:
            continue
        if change.uas_id == SPOOFER_ID and math.isnan(metrics.alert_s):
            metrics.alert_s, metrics.alert_detector = now, change.detector
        elif change.uas_id != SPOOFER_ID:
            metrics.false_alerts += 1
    if keep:
        metrics.results.extend((r.uas_id == SPOOFER_ID, r) for r in out.detector_results)
    truth = traffic.spoofer_path.at(now)[0] if traffic.scene.with_spoofer else None
    for region in out.regions:
        if region.uas_id != SPOOFER_ID or truth is None:
            continue
        if math.isnan(metrics.first_region_s):
            metrics.first_region_s = now
        d = truth - region.center_enu_m
        m2 = float(d @ np.linalg.solve(region.cov_enu_m2, d))
        metrics.containment.append(m2 <= region.chi2_threshold)
        metrics.nees.append(m2)
        metrics.errors_m.append(float(np.linalg.norm(d)))
        metrics.errors_h_m.append(float(np.linalg.norm(d[:2])))
