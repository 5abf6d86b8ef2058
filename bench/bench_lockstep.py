"""Benchmark: how many times faster than real time a lockstep run flies 16 benign aircraft and
the spoofer for 120 s (sim backend, 16 companions, GCS and recorder, every MAVLink byte).

    python bench/bench_lockstep.py [--planner straight-line|aware|trust-rid] [--aircraft 16]

Prints wall time, speed-up and where the time went (per core, from a profile-free split).
Target (issue): >= 20x real time on the 2-core development machine.
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import tempfile
import time
from pathlib import Path

from ridsafe.tools.lockstep import run_lockstep
from ridsafe.tools.metrics import compute_metrics
from ridsafe.tools.scenario import load_scenario_file, with_aircraft


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--planner", default="straight-line")
    parser.add_argument("--aircraft", type=int, default=16)
    parser.add_argument("--duration", type=float, default=120.0)
    parser.add_argument("--tick", type=float, help="lockstep tick (s), default the config's")
    args = parser.parse_args()
    logging.basicConfig(level=logging.ERROR)
    loaded = with_aircraft(load_scenario_file(), args.aircraft)
    loaded = dataclasses.replace(
        loaded, scenario=dataclasses.replace(loaded.scenario, duration_s=args.duration)
    )
    if args.tick is not None:
        loaded = dataclasses.replace(
            loaded, run=dataclasses.replace(loaded.run, lockstep_tick_s=args.tick)
        )
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        result = run_lockstep(loaded, args.planner, Path(tmp) / "run.mcap")
        wall = time.perf_counter() - start
        metrics = compute_metrics(result.log_path)
    speedup = result.sim_time_s / wall
    print(
        f"lockstep, {args.aircraft} aircraft + spoofer, {result.sim_time_s:.0f} s sim, "
        f"tick {loaded.run.lockstep_tick_s * 1000:.0f} ms, planner {args.planner}"
    )
    print(f"  wall clock        {wall:8.2f} s")
    print(f"  speed-up          {speedup:8.1f}x real time   (target >= 20x)")
    print(f"  GCS compute       {metrics['gcs_compute_s']:8.2f} s")
    p99 = metrics["planner_decision_p99_ms"]
    print(f"  planner p99       {p99:8.2f} ms per decision" if p99 is not None else "")


if __name__ == "__main__":
    main()
