"""Seed sweep of the planner-only closed loop: aware vs trust-rid on the same seeds.

Uses ``ridsafe.tools.planner_loop`` (16 aircraft from 3 depots in 1 km x 1 km, a
spoofer crossing the traffic at 60 m with RID offset (+50, +50, 0) m ENU, regions around its
true position with an honest covariance). Prints one line per seed and planner, then the
means and standard deviations next to the paper's Table 2 (16 aircraft).

Run: ``.venv/bin/python bench/planner_closed_loop.py [--seeds 30] [--dynamics 6dof]``
"""

from __future__ import annotations

import argparse
import logging
import time
from dataclasses import replace

import numpy as np

from ridsafe.tools.planner_loop.closed_loop import PLANNERS, RunResult, run_closed_loop
from ridsafe.tools.planner_loop.fleets import FLEETS
from ridsafe.tools.planner_loop.layout import HarnessConfig

# Paper Table 2, 16 agents: (benign-benign, benign-spoofer) NMACs per run.
PAPER = {"aware": (6.767, 0.233), "trust-rid": (6.767, 2.200)}


def _row(r: RunResult, wall_s: float) -> str:
    p50, p99 = np.percentile(r.decision_ms, [50, 99])
    return (
        f"{r.planner:9s} seed {r.seed:3d}  NMAC benign {r.nmac_benign:2d}  spoofer "
        f"{r.nmac_spoofer:2d}  ellipsoid entries {r.region_entries:3d}  reached "
        f"{r.reached:2d}/{r.n_aircraft}  min d spoofer {r.min_spoofer_distance_m:6.1f} m  "
        f"decision p50 {p50:.2f} p99 {p99:.2f} ms  ({wall_s:.1f} s)"
    )


def _summary(planner: str, results: list[RunResult]) -> str:
    def ms(values: list[float]) -> str:
        return (
            f"{np.mean(values):6.3f} +/- {np.std(values, ddof=1) if len(values) > 1 else 0.0:5.3f}"
        )

    reached = sum(r.reached for r in results) / sum(r.n_aircraft for r in results)
    decisions = np.concatenate([r.decision_ms for r in results])
    p50, p99 = np.percentile(decisions, [50, 99])
    paper_bb, paper_bs = PAPER[planner]
    return (
        f"{planner:9s} benign-benign {ms([r.nmac_benign for r in results])} (paper {paper_bb})"
        f"  benign-spoofer {ms([r.nmac_spoofer for r in results])} (paper {paper_bs})"
        f"  ellipsoid entries {ms([r.region_entries for r in results])}"
        f"  reached {100 * reached:5.1f} %"
        f"  runs with a spoofer NMAC {sum(r.nmac_spoofer > 0 for r in results)}/{len(results)}"
        f"  decision p50 {p50:.2f} p99 {p99:.2f} ms"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=30)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--aircraft", type=int, default=16)
    parser.add_argument("--duration", type=float, default=120.0)
    parser.add_argument("--dynamics", choices=sorted(FLEETS), default="kinematic")
    parser.add_argument("--planners", default="aware,trust-rid")
    parser.add_argument(
        "--region-error-scale",
        type=float,
        default=1.0,
        help="true spoofer-estimate error / reported std (>1: the GCS is overconfident)",
    )
    args = parser.parse_args()
    logging.disable(logging.WARNING)
    cfg = replace(
        HarnessConfig(),
        n_aircraft=args.aircraft,
        duration_s=args.duration,
        region_error_scale=args.region_error_scale,
    )
    planners = [p for p in args.planners.split(",") if p in PLANNERS]
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    print(f"{cfg.n_aircraft} aircraft, {cfg.duration_s:g} s, {args.dynamics}, seeds {list(seeds)}")
    results: dict[str, list[RunResult]] = {p: [] for p in planners}
    for seed in seeds:
        for planner in planners:
            t0 = time.perf_counter()
            result = run_closed_loop(planner, seed, cfg, dynamics=args.dynamics)
            results[planner].append(result)
            print(_row(result, time.perf_counter() - t0), flush=True)
    print()
    for planner in planners:
        print(_summary(planner, results[planner]))


if __name__ == "__main__":
    main()
