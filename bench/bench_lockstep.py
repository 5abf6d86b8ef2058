"""Benchmark: how many times faster than real time a lockstep run flies 16 benign aircraft and
the spoofer for 120 s (sim backend, 16 companions, GCS and recorder, every MAVLink byte).

    python bench/bench_lockstep.py [--planner straight-line|aware|trust-rid] [--aircraft 16]
                                   [--repeat 3] [--tick S]

Each repetition is a fresh Python process timing one ``run_lockstep`` call, as
``ridsafe run --mode lockstep`` makes it: building the cores (the numba kernels load from
their cache), the flight, and the log written and closed (by the recorder's own process).
Interpreter start and imports are not counted. The machine is shared, so one run can be
10 % off; the verdict uses the median of the repetitions.
Target (issue): >= 20x real time on the 2-core development machine.
"""

from __future__ import annotations

import os

# As the ridsafe command line does (ridsafe/tools/cli/entry_point.py): no BLAS worker threads.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import json  # noqa: E402
import logging  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

TARGET_SPEEDUP = 20.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--planner", default="straight-line")
    parser.add_argument("--aircraft", type=int, default=16)
    parser.add_argument("--duration", type=float, default=120.0)
    parser.add_argument("--tick", type=float, help="lockstep tick (s), default the config's")
    parser.add_argument("--repeat", type=int, default=3, help="fresh processes, one run each")
    parser.add_argument("--once", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.once:
        print(json.dumps(_one_run(args)))
        return
    if args.repeat < 1:
        parser.error("--repeat must be >= 1")
    argv = [sys.executable, __file__, "--once", *sys.argv[1:]]
    runs = []
    for k in range(args.repeat):
        done = subprocess.run(argv, capture_output=True, text=True, check=True)
        runs.append(json.loads(done.stdout.strip().splitlines()[-1]))
        run = runs[-1]
        print(
            f"  run {k + 1}/{args.repeat}: wall clock {run['wall_s']:6.2f} s "
            f"(cores built in {run['build_s']:.2f} s), "
            f"{run['sim_s'] / run['wall_s']:5.1f}x real time",
            flush=True,
        )
    last = runs[-1]
    walls = [run["wall_s"] for run in runs]
    median = statistics.median(walls)
    speedup = last["sim_s"] / median
    print(
        f"lockstep, {args.aircraft} aircraft + spoofer, {last['sim_s']:.0f} s sim, "
        f"tick {last['tick_s'] * 1000:.0f} ms, planner {args.planner}, {len(runs)} runs"
    )
    spread = f"median; min {min(walls):.2f}, max {max(walls):.2f}"
    print(f"  wall clock        {median:8.2f} s   ({spread})")
    verdict = "met" if speedup >= TARGET_SPEEDUP else "NOT met"
    target = f"target >= {TARGET_SPEEDUP:g}x: {verdict}"
    print(f"  speed-up          {speedup:8.1f}x real time   ({target})")
    print(f"  GCS compute       {last['gcs_compute_s']:8.2f} s")
    p99 = last["planner_p99_ms"]
    if p99 is not None:
        print(f"  planner p99       {p99:8.2f} ms per decision")


def _one_run(args: argparse.Namespace) -> dict[str, float | None]:
    from ridsafe.tools.analysis.metrics import compute_metrics  # noqa: PLC0415 (not timed)
    from ridsafe.tools.run import lockstep  # noqa: PLC0415
    from ridsafe.tools.run.scenario import load_scenario_file, with_aircraft  # noqa: PLC0415

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
        result = lockstep.run_lockstep(loaded, args.planner, Path(tmp) / "run.mcap")
        wall = time.perf_counter() - start
        metrics = compute_metrics(result.log_path)
    return {
        "wall_s": wall,
        "build_s": result.build_s,
        "sim_s": result.sim_time_s,
        "tick_s": loaded.run.lockstep_tick_s,
        "gcs_compute_s": metrics["gcs_compute_s"],
        "planner_p99_ms": metrics["planner_decision_p99_ms"],
    }


if __name__ == "__main__":
    main()
