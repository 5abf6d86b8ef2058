"""The planner-only closed loop's world: its configuration and the seeded layout.

One shared NED frame (x north, y east, z down, metres), sim time from 0. Layout (seeded): a
square area of side 2 ``area_half_m``; three depots; aircraft k starts hovering at its cruise
altitude (drawn from ``cruise_alts_m``) above a pad on a ring of radius ``pad_ring_m`` around
depot k mod 3, and launches at ``launch_interval_s`` times its slot at the depot; its delivery
site is drawn in the area ``goal_min_m``-``goal_max_m`` from its pad, at least
``goal_spacing_m`` from other sites, at its cruise altitude. The spoofer flies a straight line
at ``spoofer_speed_m_s`` and ``spoofer_alt_m`` through a point near the centre, in a random
direction, avoiding nobody.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["SPOOFER_ID", "HarnessConfig", "Layout", "make_layout", "t3"]

FloatArray = NDArray[np.float64]

SPOOFER_ID = "SPOOFER"


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


def t3(x: FloatArray) -> tuple[float, float, float]:
    """A 3-vector as the planner's tuple of floats."""
    return (float(x[0]), float(x[1]), float(x[2]))
