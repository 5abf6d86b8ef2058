"""Closed-loop, planner-only simulation: N benign aircraft, each with a planner, and a spoofer.

Not the lockstep system (no MAVLink, radio or GCS): the smallest world that closes the loop
around the planner, so its safety can be measured alone.

World: one shared NED frame (x north, y east, z down, metres), sim time from 0, step ``dt_s``.

- **Layout** (seeded) and **spoofer** line: ``layout.make_layout``.
- **Aircraft**: ``fleets.KinematicFleet`` (the autopilot's position and velocity laws on point
  masses) or ``fleets.SixDofFleet`` (the sim's octorotors with the real cascade).
- **RID**: every aircraft broadcasts its true position and velocity at ``rid_period_s`` (random
  phase); neighbours are the others' latest broadcasts. The spoofer broadcasts its true state
  plus ``spoofer_offset_ned_m`` and is flagged from ``alert_s``.
- **Unsafe region** (from ``alert_s``, every ``gcs_period_s``, valid 1 s): an ellipsoid whose
  centre is the true position plus an AR(1) error with stationary covariance P (so the region
  contains the truth at its nominal rate, errors correlated over ``region_corr_s``); P has
  horizontal standard deviations drawn from ``region_std_h_m`` in a random orientation and
  ``region_std_v_m`` vertically; the velocity estimate has its own AR(1) error. With
  ``region_error_scale`` > 1 the errors are larger than P says (an overconfident GCS; the
  paper's containment was 0.84, not 0.95).
- **Arrival**: a planner that reports ``ARRIVED`` has reached its goal; with ``LAND`` it
  leaves the airspace once below 0.5 m (no more RID, no NMACs).
- **Metrics** (events, not samples, counted as the run metrics count them:
  ``ridsafe.tools.analysis.encounters``): a pair closer than ``nmac_m`` is one NMAC until it
  is ``nmac_m`` apart again; benign-benign, benign-true spoofer, and benign entries into the
  published ellipsoid; goals reached; planner time per decision.

``bench/planner_closed_loop.py`` sweeps it over seeds; ``scripted`` has the small encounters
the planner's unit tests fly.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from ridsafe.common import ellipsoid
from ridsafe.companion.planner import AwarePlanner, FastMdpPlanner, TrustRidPlanner
from ridsafe.companion.planner_api import Neighbour, PlannerInput, PlannerStatus, Region
from ridsafe.companion.planner_config import ArrivalAction, PlannerConfig
from ridsafe.tools.analysis.encounters import count_entries
from ridsafe.tools.planner_loop.fleets import FLEETS, Fleet
from ridsafe.tools.planner_loop.layout import SPOOFER_ID, HarnessConfig, Layout, make_layout, t3

__all__ = ["PLANNERS", "RegionSource", "RunResult", "run_closed_loop"]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

PLANNERS: dict[str, Callable[[PlannerConfig], FastMdpPlanner]] = {
    "aware": AwarePlanner,
    "trust-rid": TrustRidPlanner,
}
_LANDED_ALT_M = 0.5


@dataclass(frozen=True)
class RunResult:
    planner: str
    seed: int
    nmac_benign: int
    nmac_spoofer: int
    region_entries: int
    reached: int
    n_aircraft: int
    min_spoofer_distance_m: float
    decision_ms: FloatArray
    statuses: Counter[str] = field(default_factory=Counter)

    @property
    def reached_fraction(self) -> float:
        return self.reached / self.n_aircraft


class RegionSource:
    """Unsafe regions around the true spoofer: centre = truth + AR(1) error with stationary
    covariance P, velocity = truth + AR(1) error of ``region_v_std_m_s`` per axis."""

    def __init__(self, cfg: HarnessConfig, cov: FloatArray, rng: np.random.Generator) -> None:
        self.cfg, self.cov, self.rng = cfg, cov, rng
        self._chol = cfg.region_error_scale * np.linalg.cholesky(cov)
        self._rho = math.exp(-cfg.gcs_period_s / cfg.region_corr_s)
        self._e_p = self._chol @ rng.standard_normal(3)
        self._e_v = cfg.region_v_std_m_s * rng.standard_normal(3)

    def update(self, t_s: float, p_true: FloatArray, v_true: FloatArray) -> Region:
        rho, k = self._rho, math.sqrt(1.0 - self._rho**2)
        self._e_p = rho * self._e_p + k * (self._chol @ self.rng.standard_normal(3))
        self._e_v = rho * self._e_v + k * self.cfg.region_v_std_m_s * self.rng.standard_normal(3)
        c, v = p_true + self._e_p, v_true + self._e_v
        cov = (t3(self.cov[0]), t3(self.cov[1]), t3(self.cov[2]))
        return Region(SPOOFER_ID, t3(c), cov, self.cfg.chi2_threshold, t3(v), t_s, t_s + 1.0)


@dataclass
class _World:
    """Mutable state of one run."""

    cfg: HarnessConfig
    layout: Layout
    fleet: Fleet
    planners: list[FastMdpPlanner]
    regions: RegionSource
    rid: list[Neighbour | None]
    rid_due_s: FloatArray
    active: BoolArray
    launched: BoolArray
    done: BoolArray
    spoofer_p: FloatArray
    region: Region | None = None
    decision_ms: list[float] = field(default_factory=list)
    statuses: Counter[str] = field(default_factory=Counter)


def _broadcast(w: _World, t_s: float) -> None:
    """RID at ``rid_period_s``: benign aircraft 0..N-1 (true), the spoofer last (offset)."""
    n = w.cfg.n_aircraft
    for i in np.flatnonzero(w.rid_due_s <= t_s + 1e-9):
        w.rid_due_s[i] += w.cfg.rid_period_s
        if i == n:
            p = w.spoofer_p + np.asarray(w.cfg.spoofer_offset_ned_m)
            v, uas, flagged = w.layout.spoofer_v_ned_m_s, SPOOFER_ID, t_s >= w.cfg.alert_s
        elif w.active[i]:
            p, v, uas, flagged = w.fleet.p[i], w.fleet.v[i], f"B{i:02d}", False
        else:
            w.rid[i] = None
            continue
        w.rid[i] = Neighbour(uas, t3(p), t3(v), t_s, flagged)


def _decide(w: _World, t_s: float) -> None:
    region = () if w.region is None else (w.region,)
    for i in map(int, np.flatnonzero(w.active)):
        neighbours = tuple(r for j, r in enumerate(w.rid) if r is not None and j != i)
        if t_s >= w.cfg.alert_s:  # the alert reaches every companion
            neighbours = tuple(replace(r, flagged=r.uas_id == SPOOFER_ID) for r in neighbours)
        inp = PlannerInput(
            t_s,
            t3(w.fleet.p[i]),
            t3(w.fleet.v[i]),
            t3(w.layout.goal_ned_m[i]),
            neighbours,
            region,
        )
        t0 = time.perf_counter()
        decision = w.planners[i].plan(inp)
        w.decision_ms.append(1e3 * (time.perf_counter() - t0))
        w.statuses[decision.status.value] += 1
        w.fleet.set_target(
            i, np.asarray(decision.target_p_ned_m), np.asarray(decision.target_v_ned_m_s)
        )
        if decision.status is PlannerStatus.ARRIVED:
            w.done[i] = True


def _update_active(w: _World, t_s: float, planner_cfg: PlannerConfig) -> None:
    """Launch aircraft whose time has come; retire those that landed at their goal."""
    for i in map(int, np.flatnonzero(~w.launched & (w.layout.launch_s <= t_s + 1e-9))):
        w.fleet.place(i, w.layout.start_ned_m[i])
        w.active[i] = w.launched[i] = True
    if planner_cfg.on_arrival is ArrivalAction.LAND:
        landed = w.done & w.active & (-w.fleet.p[:, 2] < _LANDED_ALT_M)
        w.active[landed] = False


def _distances(w: _World) -> tuple[FloatArray, FloatArray]:
    """Benign pair distances (N, N) (inf for inactive / self) and to the true spoofer (N,)."""
    p = w.fleet.p
    d = np.linalg.norm(p[:, None, :] - p[None, :, :], axis=-1)
    off = ~(w.active[:, None] & w.active[None, :]) | np.eye(len(p), dtype=np.bool_)
    d[off] = np.inf
    ds = np.linalg.norm(p - w.spoofer_p, axis=1)
    ds[~w.active] = np.inf
    return d, ds


def _in_region(w: _World) -> BoolArray:
    if w.region is None:
        return np.zeros(w.cfg.n_aircraft, dtype=np.bool_)
    region = w.region
    entered: BoolArray = (
        ellipsoid.inside(w.fleet.p, region.center_ned_m, region.cov_ned_m2, region.chi2_threshold)
        & w.active
    )
    return entered


def run_closed_loop(
    planner: str,
    seed: int,
    cfg: HarnessConfig | None = None,
    planner_config: PlannerConfig | None = None,
    dynamics: str = "kinematic",
) -> RunResult:
    """One seeded run of ``cfg.n_aircraft`` aircraft flown by ``planner`` planners."""
    cfg = cfg if cfg is not None else HarnessConfig()
    pcfg = (
        planner_config
        if planner_config is not None
        else PlannerConfig(on_arrival=ArrivalAction.LAND)
    )
    layout = make_layout(cfg, seed)
    rng = np.random.default_rng([seed, 1])
    n = cfg.n_aircraft
    w = _World(
        cfg,
        layout,
        FLEETS[dynamics](layout.start_ned_m),
        [PLANNERS[planner](pcfg) for _ in range(n)],
        RegionSource(cfg, layout.region_cov_ned_m2, rng),
        [None] * (n + 1),
        rng.uniform(0.0, cfg.rid_period_s, size=n + 1),
        np.zeros(n, dtype=np.bool_),
        np.zeros(n, dtype=np.bool_),
        np.zeros(n, dtype=np.bool_),
        layout.spoofer_start_ned_m.copy(),
    )
    # Per step: benign pairs (i < j), benign-spoofer, inside the region; counted as entry
    # events (analysis.encounters) at the end.
    benign: list[BoolArray] = []
    spoofer: list[BoolArray] = []
    entries: list[BoolArray] = []
    iu = np.triu_indices(n, k=1)
    min_spoofer = math.inf
    plan_every = round(cfg.replan_period_s / cfg.dt_s)
    gcs_every = round(cfg.gcs_period_s / cfg.dt_s)
    for step in range(round(cfg.duration_s / cfg.dt_s)):
        t = step * cfg.dt_s
        _update_active(w, t, pcfg)
        _broadcast(w, t)
        if t >= cfg.alert_s - 1e-9 and step % gcs_every == 0:
            w.region = w.regions.update(t, w.spoofer_p, layout.spoofer_v_ned_m_s)
        if step % plan_every == 0:
            _decide(w, t)
        w.fleet.step(cfg.dt_s)
        w.spoofer_p = w.spoofer_p + layout.spoofer_v_ned_m_s * cfg.dt_s
        d, ds = _distances(w)
        benign.append(d[iu] < cfg.nmac_m)
        spoofer.append(ds < cfg.nmac_m)
        entries.append(_in_region(w))
        min_spoofer = min(min_spoofer, float(ds.min()))
    return RunResult(
        planner,
        seed,
        _entries(benign, n * (n - 1) // 2),
        _entries(spoofer, n),
        _entries(entries, n),
        int(np.count_nonzero(w.done)),
        n,
        min_spoofer,
        np.asarray(w.decision_ms),
        w.statuses,
    )


def _entries(samples: list[BoolArray], width: int) -> int:
    """Entry events over the steps' (width,) inside masks."""
    stacked = np.array(samples, dtype=np.bool_).reshape(len(samples), width)
    return count_entries(stacked)
