"""Benchmark (not a test): planner time per decision with 16 neighbours and one unsafe region.

Every decision is a fresh random scene around an aircraft at cruise altitude: 16 neighbours
within 100 m horizontally flying up to 8 m/s (all within d_safe now, so the planner's range
gating drops none: the worst case) and one unsafe region (std 15-30 m horizontal, 40 m
vertical) 100-250 m away, also never gated out. Prints p50 / p99 /
max per decision for both planners (trust-rid sees the same scene: 17 aircraft, no region),
and a breakdown of one aware decision into its stages. Target: p99 <= 5 ms on this machine.

Run: ``.venv/bin/python bench/bench_planner.py [--decisions 3000]``
"""

from __future__ import annotations

import argparse
import logging
import math
import time

import numpy as np

from ridsafe.companion.actions import build_action_set, heading_to_rad
from ridsafe.companion.planner import AwarePlanner, FastMdpPlanner, TrustRidPlanner
from ridsafe.companion.planner_api import Neighbour, PlannerInput, Region
from ridsafe.companion.planner_config import PlannerConfig
from ridsafe.companion.planner_eval import KernelParams, build_scene, score_actions

N_NEIGHBOURS = 16
CHI2_95 = 7.814727903251178
TARGET_P99_MS = 5.0


def _t3(x: np.ndarray) -> tuple[float, float, float]:
    return (float(x[0]), float(x[1]), float(x[2]))


def random_input(rng: np.random.Generator, t_s: float) -> PlannerInput:
    p = np.array([0.0, 0.0, -60.0])
    v = rng.uniform(-6.0, 6.0, 3) * [1.0, 1.0, 0.1]
    goal = np.array([*rng.uniform(-600.0, 600.0, 2), -60.0])
    neighbours = []
    for j in range(N_NEIGHBOURS):
        r, b = 100.0 * math.sqrt(rng.uniform()), rng.uniform(-math.pi, math.pi)
        q = p + np.array([r * math.cos(b), r * math.sin(b), rng.uniform(-10.0, 10.0)])
        w = rng.uniform(-8.0, 8.0, 3) * [0.7, 0.7, 0.1]
        neighbours.append(Neighbour(f"N{j}", _t3(q), _t3(w), t_s - rng.uniform(0.0, 1.0), j == 0))
    bearing, dist = rng.uniform(-math.pi, math.pi), rng.uniform(100.0, 250.0)
    c = p + dist * np.array([math.cos(bearing), math.sin(bearing), 0.0])
    s1, s2 = rng.uniform(15.0, 30.0, 2)
    cov = ((s1**2, 0.0, 0.0), (0.0, s2**2, 0.0), (0.0, 0.0, 1600.0))
    w = rng.uniform(-7.0, 7.0, 3) * [1.0, 1.0, 0.0]
    region = Region("SPOOF", _t3(c), cov, CHI2_95, _t3(w), t_s - 0.2, t_s + 1.0)
    return PlannerInput(t_s, _t3(p), _t3(v), _t3(goal), tuple(neighbours), (region,))


def time_planner(planner: FastMdpPlanner, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    inputs = [random_input(rng, 10.0 + 0.5 * i) for i in range(n)]
    planner.plan(inputs[0])  # load the compiled kernel outside the timing
    times = np.empty(n)
    for i, inp in enumerate(inputs):
        t0 = time.perf_counter()
        planner.plan(inp)
        times[i] = time.perf_counter() - t0
    return 1e3 * times


def stages(cfg: PlannerConfig, n: int, seed: int) -> dict[str, float]:
    """Median ms of the three stages of an aware decision (and of scoring every action, for
    comparison with the bounded scoring the planner runs)."""
    rng = np.random.default_rng(seed)
    kp = KernelParams.from_config(cfg)
    stage_names = ("build_scene", "build_action_set", "score_actions (bounded)", "(every action)")
    out: dict[str, list[float]] = {name: [] for name in stage_names}
    for i in range(n):
        inp = random_input(rng, 10.0 + 0.5 * i)
        p0, v0, goal = (np.asarray(x) for x in (inp.p_ned_m, inp.v_ned_m_s, inp.goal_ned_m))
        t0 = time.perf_counter()
        scene = build_scene(inp.t_s, p0, inp.neighbours[1:], inp.regions, cfg)
        t1 = time.perf_counter()
        actions = build_action_set(cfg, heading_to_rad(p0, goal))
        t2 = time.perf_counter()
        score_actions(p0, v0, goal, actions, scene, kp, cfg.right_turn_bias)  # as the planner
        t3 = time.perf_counter()
        score_actions(p0, v0, goal, actions, scene, kp)
        t4 = time.perf_counter()
        for key, dt in zip(out, (t1 - t0, t2 - t1, t3 - t2, t4 - t3), strict=True):
            out[key].append(1e3 * dt)
    return {k: float(np.median(v)) for k, v in out.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--decisions", type=int, default=3000)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    logging.disable(logging.WARNING)  # random scenes: the progress watchdog has nothing to say
    cfg = PlannerConfig()
    print(
        f"{cfg.n_actions} actions x {cfg.n_samples} samples over {cfg.horizon_s:g} s, "
        f"{N_NEIGHBOURS} neighbours (1 flagged) + 1 region, {args.decisions} decisions"
    )
    for planner in (AwarePlanner(cfg), TrustRidPlanner(cfg)):
        ms = time_planner(planner, args.decisions, args.seed)
        p50, p99 = np.percentile(ms, [50, 99])
        verdict = "meets" if p99 <= TARGET_P99_MS else "MISSES"
        print(
            f"  {planner.name:9s}  p50 {p50:5.2f} ms  p99 {p99:5.2f} ms  max {ms.max():6.2f} ms"
            f"  ({verdict} the p99 <= {TARGET_P99_MS:g} ms target)"
        )
    parts = stages(cfg, min(args.decisions, 1000), args.seed)
    print("  aware stages (median): " + ", ".join(f"{k} {v:.3f} ms" for k, v in parts.items()))


if __name__ == "__main__":
    main()
