"""Closed-loop, planner-only simulation: N benign aircraft, each with a planner, and a spoofer.

Not the lockstep system (no MAVLink, radio or GCS): the smallest world that closes the loop
around the planner, so its safety can be measured alone.

World: one shared NED frame (x north, y east, z down, metres), sim time from 0, step ``dt_s``.

- **Layout** (seeded): a square area of side 2 ``area_half_m``; three depots; aircraft k
  starts hovering at its cruise altitude (drawn from ``cruise_alts_m``) above a pad on a ring
  of radius ``pad_ring_m`` around depot k mod 3, and launches at ``launch_interval_s`` times
  its slot at the depot; its delivery site is drawn in the area ``goal_min_m``-``goal_max_m``
  from its pad, at least ``goal_spacing_m`` from other sites, at its cruise altitude.
- **Aircraft**: the autopilot's position + velocity law (``ridsafe.sim_backend.controller``
  step 1, square-root shaper with the velocity feed-forward) with its speed, climb and descent
  limits, then a velocity loop with gain k_v and the tilt / vertical acceleration limits
  (``KinematicFleet``); or the sim's 6-DoF octorotors with the real cascade (``SixDofFleet``).
- **RID**: every aircraft broadcasts its true position and velocity at ``rid_period_s`` (random
  phase); neighbours are the others' latest broadcasts. The spoofer broadcasts its true state
  plus ``spoofer_offset_ned_m`` and is flagged from ``alert_s``.
- **Spoofer**: a straight line at ``spoofer_speed_m_s`` and ``spoofer_alt_m`` through a point
  near the centre, in a random direction, avoiding nobody.
- **Unsafe region** (from ``alert_s``, every ``gcs_period_s``, valid 1 s): an ellipsoid whose
  centre is the true position plus an AR(1) error with stationary covariance P (so the region
  contains the truth at its nominal rate, errors correlated over ``region_corr_s``); P has
  horizontal standard deviations drawn from ``region_std_h_m`` in a random orientation and
  ``region_std_v_m`` vertically; the velocity estimate has its own AR(1) error. With
  ``region_error_scale`` > 1 the errors are larger than P says (an overconfident GCS; the
  paper's containment was 0.84, not 0.95).
- **Arrival**: a planner that reports ``ARRIVED`` has reached its goal; with ``LAND`` it
  leaves the airspace once below 0.5 m (no more RID, no NMACs).
- **Metrics** (events, not samples): a pair closer than ``nmac_m`` is one NMAC until it is
  ``nmac_m`` apart again; benign-benign, benign-true spoofer, and benign entries into the
  published ellipsoid; goals reached; planner time per decision.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from ridsafe.companion.planner import AwarePlanner, FastMdpPlanner, TrustRidPlanner
from ridsafe.companion.planner_api import Neighbour, PlannerInput, PlannerStatus, Region
from ridsafe.companion.planner_config import GRAVITY_M_S2, ArrivalAction, PlannerConfig
from ridsafe.sim_backend.params import ControllerParams

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

PLANNERS: dict[str, Callable[[PlannerConfig], FastMdpPlanner]] = {
    "aware": AwarePlanner,
    "trust-rid": TrustRidPlanner,
}
SPOOFER_ID = "SPOOFER"
_LANDED_ALT_M = 0.5


@dataclass(frozen=True)
class HarnessConfig:
    n_aircraft: int = 16
    duration_s: float = 120.0
    dt_s: float = 0.05
    replan_period_s: float = 0.5
    rid_period_s: float = 1.0
    area_half_m: float = 500.0
    depots_ne_m: tuple[tuple[float, float], ...] = ((-350.0, -350.0), (-350.0, 350.0), (380.0, 0.0))
    pad_ring_m: float = 60.0
    launch_interval_s: float = 0.0
    cruise_alts_m: tuple[float, ...] = (50.0, 60.0, 70.0)
    goal_min_m: float = 250.0
    goal_max_m: float = 700.0
    goal_spacing_m: float = 100.0
    spoofer_speed_m_s: float = 7.0
    spoofer_alt_m: float = 60.0
    spoofer_lead_in_m: float = 450.0  # start this far before the crossing point
    spoofer_clearance_m: float = 200.0  # and at least this far from every pad
    spoofer_offset_ned_m: tuple[float, float, float] = (50.0, 50.0, 0.0)  # ENU (+50, +50, 0)
    alert_s: float = 5.0
    gcs_period_s: float = 0.25
    region_std_h_m: tuple[float, float] = (15.0, 30.0)
    region_std_v_m: float = 40.0
    region_corr_s: float = 5.0
    region_error_scale: float = 1.0  # true error std / reported std (> 1: overconfident GCS)
    region_v_std_m_s: float = 1.0
    chi2_threshold: float = 7.814727903251178  # chi2_3 at 1 - alpha, alpha = 0.05
    nmac_m: float = 50.0


@dataclass(frozen=True)
class Layout:
    start_ned_m: FloatArray  # (N, 3)
    goal_ned_m: FloatArray  # (N, 3)
    launch_s: FloatArray  # (N,)
    spoofer_start_ned_m: FloatArray  # (3,)
    spoofer_v_ned_m_s: FloatArray  # (3,)
    region_cov_ned_m2: FloatArray  # (3, 3)


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


def make_layout(cfg: HarnessConfig, seed: int) -> Layout:
    """The seeded scenario: pads, delivery sites, spoofer line and region covariance."""
    rng = np.random.default_rng(seed)
    n, n_depots = cfg.n_aircraft, len(cfg.depots_ne_m)
    start, goal = np.zeros((n, 3)), np.zeros((n, 3))
    launch = np.zeros(n)
    per_depot = math.ceil(n / n_depots)
    for i in range(n):
        depot, slot = i % n_depots, i // n_depots
        angle = 2.0 * math.pi * slot / per_depot + 0.5 * depot
        centre = np.asarray(cfg.depots_ne_m[depot])
        alt = float(rng.choice(cfg.cruise_alts_m))
        pad = centre + cfg.pad_ring_m * np.array([math.cos(angle), math.sin(angle)])
        start[i] = (pad[0], pad[1], -alt)
        goal[i] = (*_delivery_site(rng, pad, goal[:i, :2], cfg), -alt)
        launch[i] = slot * cfg.launch_interval_s
    spoofer_start, direction = _spoofer_line(rng, start, cfg)
    std_h = rng.uniform(*cfg.region_std_h_m, size=2)
    axes = rng.uniform(0.0, math.pi)
    rot = np.array([[math.cos(axes), -math.sin(axes)], [math.sin(axes), math.cos(axes)]])
    cov = np.zeros((3, 3))
    cov[:2, :2] = rot @ np.diag(std_h**2) @ rot.T
    cov[2, 2] = cfg.region_std_v_m**2
    return Layout(start, goal, launch, spoofer_start, cfg.spoofer_speed_m_s * direction, cov)


def _spoofer_line(
    rng: np.random.Generator, pads: FloatArray, cfg: HarnessConfig
) -> tuple[FloatArray, FloatArray]:
    """(start, unit direction): ``spoofer_lead_in_m`` before a crossing point near the centre,
    starting at least ``spoofer_clearance_m`` from every pad."""
    for _ in range(1000):
        crossing = rng.uniform(-150.0, 150.0, size=2)
        course = rng.uniform(0.0, 2.0 * math.pi)
        direction = np.array([math.cos(course), math.sin(course), 0.0])
        start = np.array([*crossing, -cfg.spoofer_alt_m]) - cfg.spoofer_lead_in_m * direction
        if np.min(np.linalg.norm(pads[:, :2] - start[:2], axis=1)) >= cfg.spoofer_clearance_m:
            return start, direction
    raise RuntimeError("no spoofer line keeps clear of the depots")


def _delivery_site(
    rng: np.random.Generator, pad: FloatArray, others: FloatArray, cfg: HarnessConfig
) -> tuple[float, float]:
    lim = cfg.area_half_m * 0.9
    for _ in range(1000):
        site = rng.uniform(-lim, lim, size=2)
        far_enough = cfg.goal_min_m <= float(np.linalg.norm(site - pad)) <= cfg.goal_max_m
        if far_enough and (
            others.size == 0 or np.min(np.linalg.norm(others - site, axis=1)) >= cfg.goal_spacing_m
        ):
            return float(site[0]), float(site[1])
    raise RuntimeError("no delivery site satisfies the layout constraints")


# ------------------------------------------------------------------------------------------------
# Aircraft models


class Fleet(Protocol):
    p: FloatArray  # (N, 3) NED
    v: FloatArray  # (N, 3) NED

    def set_target(self, i: int, p_ned_m: FloatArray, v_ned_m_s: FloatArray) -> None: ...

    def place(self, i: int, p_ned_m: FloatArray) -> None: ...

    def step(self, dt_s: float) -> None: ...


def _shaped(d: FloatArray, gain: float, decel: float) -> FloatArray:
    """The autopilot's square-root shaper (``controller.shaped_speed``), vectorised."""
    linear = decel / gain**2
    speed: FloatArray = np.where(
        d <= linear, gain * d, np.sqrt(2.0 * decel * np.maximum(d - 0.5 * linear, 0.0))
    )
    return speed


class KinematicFleet:
    """Point masses flown by the autopilot's position + velocity law and limits (NED)."""

    def __init__(self, p_ned_m: FloatArray, ctrl: ControllerParams | None = None) -> None:
        self.ctrl = ctrl if ctrl is not None else ControllerParams()
        self.p = p_ned_m.astype(np.float64).copy()
        self.v = np.zeros_like(self.p)
        self.p_target = self.p.copy()
        self.v_target = np.zeros_like(self.p)

    def set_target(self, i: int, p_ned_m: FloatArray, v_ned_m_s: FloatArray) -> None:
        self.p_target[i], self.v_target[i] = p_ned_m, v_ned_m_s

    def place(self, i: int, p_ned_m: FloatArray) -> None:
        self.p[i] = self.p_target[i] = p_ned_m
        self.v[i] = self.v_target[i] = 0.0

    def step(self, dt_s: float) -> None:
        c = self.ctrl
        e = self.p_target - self.p
        d_xy = np.hypot(e[:, 0], e[:, 1])
        s_xy = _shaped(d_xy, c.pos_gain_1_s, c.pos_decel_xy_m_s2)
        unit = np.divide(
            e[:, :2], d_xy[:, None], out=np.zeros((len(e), 2)), where=d_xy[:, None] > 1e-9
        )
        v_cmd = self.v_target.copy()
        v_cmd[:, :2] += s_xy[:, None] * unit
        v_cmd[:, 2] += np.sign(e[:, 2]) * _shaped(
            np.abs(e[:, 2]), c.pos_gain_1_s, c.pos_decel_z_m_s2
        )
        sxy = np.hypot(v_cmd[:, 0], v_cmd[:, 1])
        v_cmd[:, :2] *= np.minimum(1.0, c.max_speed_m_s / np.maximum(sxy, 1e-9))[:, None]
        v_cmd[:, 2] = np.clip(v_cmd[:, 2], -c.max_climb_m_s, c.max_descent_m_s)
        a = np.empty_like(self.v)
        a[:, :2] = c.vel_gain_xy_1_s * (v_cmd[:, :2] - self.v[:, :2])
        a_max = GRAVITY_M_S2 * math.tan(math.radians(c.max_tilt_deg))
        axy = np.hypot(a[:, 0], a[:, 1])
        a[:, :2] *= np.minimum(1.0, a_max / np.maximum(axy, 1e-9))[:, None]
        a[:, 2] = np.clip(
            c.vel_gain_z_1_s * (v_cmd[:, 2] - self.v[:, 2]),
            -c.max_accel_up_m_s2,
            c.max_accel_down_m_s2,
        )
        self.v += a * dt_s
        self.p += self.v * dt_s


def _ned_to_enu(x: FloatArray) -> FloatArray:
    return np.stack([x[..., 1], x[..., 0], -x[..., 2]], axis=-1)


class SixDofFleet:
    """The sim's octorotors (eq. 2 dynamics, cascaded controller), seen in NED."""

    def __init__(self, p_ned_m: FloatArray, ctrl: ControllerParams | None = None) -> None:
        from ridsafe.sim_backend.dynamics import POS_ENU, STATE_SIZE  # noqa: PLC0415
        from ridsafe.sim_backend.vehicles import OctorotorFleet  # noqa: PLC0415

        n = p_ned_m.shape[0]
        state = np.zeros((n, STATE_SIZE))
        state[:, POS_ENU] = _ned_to_enu(p_ned_m)
        self._fleet = OctorotorFleet(n, controller=ctrl, initial_state=state)
        self._pos, self._n_state = POS_ENU, STATE_SIZE
        for i in range(n):
            self._fleet.arm(i)
            self._fleet.set_target(i, position_enu_m=state[i, POS_ENU])
        self._fleet.advance(1)  # compile outside the loop
        self.p, self.v = p_ned_m.copy(), np.zeros_like(p_ned_m)
        self._read()

    def _read(self) -> None:
        from ridsafe.sim_backend.dynamics import VEL_ENU  # noqa: PLC0415

        s = self._fleet.state
        self.p, self.v = _ned_to_enu(s[:, self._pos]), _ned_to_enu(s[:, VEL_ENU])

    def set_target(self, i: int, p_ned_m: FloatArray, v_ned_m_s: FloatArray) -> None:
        self._fleet.set_target(
            i, position_enu_m=_ned_to_enu(p_ned_m), velocity_enu_m_s=_ned_to_enu(v_ned_m_s)
        )

    def place(self, i: int, p_ned_m: FloatArray) -> None:
        state = np.zeros(self._n_state)
        state[self._pos] = _ned_to_enu(p_ned_m)
        self._fleet.set_state(i, state)
        self._fleet.set_target(i, position_enu_m=state[self._pos])
        self._read()

    def step(self, dt_s: float) -> None:
        self._fleet.advance(round(dt_s * self._fleet.controller.controller_hz))
        self._read()


FLEETS: dict[str, Callable[[FloatArray], Fleet]] = {
    "kinematic": KinematicFleet,
    "6dof": SixDofFleet,
}


# ------------------------------------------------------------------------------------------------
# The GCS stand-in and the metrics


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
        cov = (_t3(self.cov[0]), _t3(self.cov[1]), _t3(self.cov[2]))
        return Region(SPOOFER_ID, _t3(c), cov, self.cfg.chi2_threshold, _t3(v), t_s, t_s + 1.0)


class EventCounter:
    """Counts entries into a boolean condition per key (``True`` after ``False``)."""

    def __init__(self, shape: tuple[int, ...]) -> None:
        self.inside = np.zeros(shape, dtype=np.bool_)
        self.count = 0

    def update(self, inside: BoolArray) -> None:
        self.count += int(np.count_nonzero(inside & ~self.inside))
        self.inside = inside.copy()


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
        w.rid[i] = Neighbour(uas, _t3(p), _t3(v), t_s, flagged)


def _t3(x: FloatArray) -> tuple[float, float, float]:
    return (float(x[0]), float(x[1]), float(x[2]))


def _decide(w: _World, t_s: float) -> None:
    region = () if w.region is None else (w.region,)
    for i in map(int, np.flatnonzero(w.active)):
        neighbours = tuple(r for j, r in enumerate(w.rid) if r is not None and j != i)
        if t_s >= w.cfg.alert_s:  # the alert reaches every companion
            neighbours = tuple(replace(r, flagged=r.uas_id == SPOOFER_ID) for r in neighbours)
        inp = PlannerInput(
            t_s,
            _t3(w.fleet.p[i]),
            _t3(w.fleet.v[i]),
            _t3(w.layout.goal_ned_m[i]),
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
    delta = w.fleet.p - np.asarray(w.region.center_ned_m)
    m = np.einsum("ni,ij,nj->n", delta, np.linalg.inv(np.asarray(w.region.cov_ned_m2)), delta)
    inside: BoolArray = (m <= w.region.chi2_threshold) & w.active
    return inside


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
    benign, spoofer, entries = EventCounter((n, n)), EventCounter((n,)), EventCounter((n,))
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
        benign.update(np.triu(d < cfg.nmac_m))
        spoofer.update(ds < cfg.nmac_m)
        entries.update(_in_region(w))
        min_spoofer = min(min_spoofer, float(ds.min()))
    return RunResult(
        planner,
        seed,
        benign.count,
        spoofer.count,
        entries.count,
        int(np.count_nonzero(w.done)),
        n,
        min_spoofer,
        np.asarray(w.decision_ms),
        w.statuses,
    )


# ------------------------------------------------------------------------------------------------
# Small scripted encounters (unit tests)


@dataclass(frozen=True)
class ScriptedSpoofer:
    """A spoofer on a straight line; its region is centred on the truth (no estimation error)."""

    start_ned_m: tuple[float, float, float]
    v_ned_m_s: tuple[float, float, float] = (0.0, 0.0, 0.0)
    offset_ned_m: tuple[float, float, float] = (50.0, 50.0, 0.0)
    cov_ned_m2: tuple[float, float, float] = (400.0, 400.0, 1600.0)  # diagonal
    chi2_threshold: float = 7.814727903251178

    def state(self, t_s: float) -> tuple[FloatArray, FloatArray]:
        v = np.asarray(self.v_ned_m_s)
        return np.asarray(self.start_ned_m) + v * t_s, v

    def rid(self, t_s: float) -> Neighbour:
        p, v = self.state(t_s)
        return Neighbour(SPOOFER_ID, _t3(p + np.asarray(self.offset_ned_m)), _t3(v), t_s, True)

    def region(self, t_s: float) -> Region:
        p, v = self.state(t_s)
        c = self.cov_ned_m2
        cov = ((c[0], 0.0, 0.0), (0.0, c[1], 0.0), (0.0, 0.0, c[2]))
        return Region(SPOOFER_ID, _t3(p), cov, self.chi2_threshold, _t3(v), t_s, t_s + 1.0)


@dataclass(frozen=True)
class Encounter:
    """Positions ``(T, N, 3)`` of the aircraft and ``(T, 3)`` of the spoofer, every ``dt_s``."""

    p_ned_m: FloatArray
    spoofer_ned_m: FloatArray
    statuses: list[list[PlannerStatus]]  # per decision, per aircraft

    def min_separation_m(self) -> float:
        p = self.p_ned_m
        d = np.linalg.norm(p[:, :, None, :] - p[:, None, :, :], axis=-1)
        d[:, np.arange(p.shape[1]), np.arange(p.shape[1])] = np.inf
        return float(d.min())

    def min_spoofer_distance_m(self) -> float:
        return float(np.linalg.norm(self.p_ned_m - self.spoofer_ned_m[:, None, :], axis=-1).min())


def fly(
    planners: list[FastMdpPlanner],
    starts: list[tuple[float, float, float]],
    goals: list[tuple[float, float, float]],
    duration_s: float,
    spoofer: ScriptedSpoofer | None = None,
    dt_s: float = 0.05,
) -> Encounter:
    """Fly ``planners`` (kinematic aircraft, replanning every 0.5 s, neighbours' true states)
    against each other and an optional spoofer (RID flagged, region on the truth)."""
    fleet = KinematicFleet(np.asarray(starts, dtype=np.float64))
    n = len(planners)
    track, spoofer_track, statuses = [], [], []
    for step in range(round(duration_s / dt_s)):
        t = step * dt_s
        if step % round(0.5 / dt_s) == 0:
            row = []
            for i, planner in enumerate(planners):
                nbs = [
                    Neighbour(f"B{j}", _t3(fleet.p[j]), _t3(fleet.v[j]), t, False)
                    for j in range(n)
                    if j != i
                ]
                regions: tuple[Region, ...] = ()
                if spoofer is not None:
                    nbs.append(spoofer.rid(t))
                    regions = (spoofer.region(t),)
                inp = PlannerInput(
                    t, _t3(fleet.p[i]), _t3(fleet.v[i]), goals[i], tuple(nbs), regions
                )
                decision = planner.plan(inp)
                row.append(decision.status)
                fleet.set_target(
                    i, np.asarray(decision.target_p_ned_m), np.asarray(decision.target_v_ned_m_s)
                )
            statuses.append(row)
        fleet.step(dt_s)
        track.append(fleet.p.copy())
        spoofer_track.append(
            spoofer.state(t + dt_s)[0] if spoofer is not None else np.full(3, np.inf)
        )
    return Encounter(np.asarray(track), np.asarray(spoofer_track), statuses)
