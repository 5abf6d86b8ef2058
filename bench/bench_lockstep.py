"""Benchmark: how many times faster than real time a lockstep run flies N benign aircraft and
the spoofer for 120 s (sim backend, N companions, GCS and recorder, every MAVLink byte), for
the planners people fly (aware first) at 16 and 64 aircraft.

    python bench/bench_lockstep.py [--planners aware,trust-rid] [--aircraft 16,64]
                                   [--repeat 3] [--tick S] [--duration S] [--serial]
                                   [--by-tick]

The scenario is ``configs/default.yaml``'s family drawn for N aircraft (seed 0): beyond 16
aircraft on copies of its square kilometre, so 64 fly 2 km x 2 km with 12 depots, as the
paper's sweeps fly them. Each repetition is a fresh Python process timing one
``run_lockstep`` call, as ``ridsafe run --mode lockstep`` makes it: building the cores (the
numba kernels load from their cache), the flight (on two processes where the machine has
two CPUs: this one steps the sim and half the companions, a forked worker the GCS and the
other half; ``tools/run/lockstep_split.py``), and the log written and closed (by the recorder's own
process). Interpreter start and imports are not counted. The machine is shared, so one run
can be 10 % off; the verdict uses the median of the repetitions. Each run also reports the CPU
time of all its processes (this one, the worker and the recorder; ``time.process_time`` and
the children's ``getrusage``), the number to compare on a loaded machine, where wall clock
mostly measures the other jobs. ``--serial`` steps every core in one process (the baseline
of the two-process run; the same log). A two-process run also prints where each process
spent its ticks (``lockstep_split.PhaseTimes``). At 16 + 1 the sim is the first barrier's
longer side on most ticks, but not on the GCS's heavy ones (a cycle, a batch of reports, the
fleet's claims closing: 1-4 ms against a sim tick of 0.4-0.7 ms), where this process waits
(``waiting_gcs``, 0.8 s of a 6.8 s run in a slow hour); ``waiting_companions`` is what the
two halves of the companions differ by. ``--by-tick`` adds this process's phases by the tick's
place in its second (``PhaseTimes.by_tick``): at 64 + 1 the sim's heavy tick is the one that
delivers the fleet's RID broadcasts, and ``waiting_gcs`` falls after the GCS cycle that
follows the fleet's batch of reports.
Targets (scale issue), 2-core development machine: 16 + 1 >= 25x, 64 + 1 >= 8x real time.
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
import resource  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

#: Speed-up targets by fleet size (aircraft + the spoofer), from the scale issue.
TARGET_SPEEDUP_BY_AIRCRAFT = {16: 25.0, 64: 8.0}


def _int_list(text: str) -> list[int]:
    return [int(part) for part in text.split(",") if part]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--planners", default="aware,trust-rid", help="comma list, in order")
    parser.add_argument("--aircraft", type=_int_list, default=[16, 64], help="comma list")
    parser.add_argument("--duration", type=float, default=120.0)
    parser.add_argument("--tick", type=float, help="lockstep tick (s), default the config's")
    parser.add_argument("--repeat", type=int, default=3, help="fresh processes, one run each")
    parser.add_argument("--serial", action="store_true", help="every core in one process")
    parser.add_argument(
        "--by-tick",
        action="store_true",
        help="also print where in its second this process spends and waits (split runs)",
    )
    parser.add_argument("--once", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--planner", help=argparse.SUPPRESS)  # one cell, for --once
    args = parser.parse_args()
    if args.once:
        print(json.dumps(_one_run(args, args.planner, args.aircraft[0])))
        return
    if args.repeat < 1:
        parser.error("--repeat: must be >= 1")
    rows = []
    for n in args.aircraft:
        for planner in (p for p in args.planners.split(",") if p):
            rows.append(_cell(args, planner, n))
    print(
        "\n| planner | aircraft | wall clock (median, s) | speed-up | target "
        "| CPU, all processes (median, s) | GCS compute (s) | planner p99 (ms) |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for row in rows:
        print(row)


def _cell(args: argparse.Namespace, planner: str, n_aircraft: int) -> str:
    """``args.repeat`` fresh processes of one (planner, N); the cell's table row."""
    base = [sys.executable, __file__, "--once", "--planner", planner, "--aircraft", str(n_aircraft)]
    base += ["--duration", str(args.duration)] + (["--serial"] if args.serial else [])
    if args.tick is not None:
        base += ["--tick", str(args.tick)]
    runs = []
    for k in range(args.repeat):
        done = subprocess.run(base, capture_output=True, text=True, check=True)
        runs.append(json.loads(done.stdout.strip().splitlines()[-1]))
        run = runs[-1]
        print(
            f"  {planner:>13s} {n_aircraft:3d} + 1, run {k + 1}/{args.repeat}: wall clock "
            f"{run['wall_s']:6.2f} s (cores built in {run['build_s']:.2f} s), "
            f"{run['sim_s'] / run['wall_s']:5.1f}x real time, CPU {run['cpu_s']:6.2f} s",
            flush=True,
        )
        if run["phases"] is not None:
            print(f"{'':19s}{_phases_line(run['phases'])}", flush=True)
        if args.by_tick and run["phases_by_tick"] is not None:
            print(_by_tick_table(run["phases_by_tick"], run["tick_s"]), flush=True)
    walls = [run["wall_s"] for run in runs]
    median = statistics.median(walls)
    cpu = statistics.median(run["cpu_s"] for run in runs)
    last = runs[-1]
    speedup = last["sim_s"] / median
    target = TARGET_SPEEDUP_BY_AIRCRAFT.get(n_aircraft)
    verdict = (
        "-" if target is None else f">= {target:g}x: {'met' if speedup >= target else 'NOT met'}"
    )
    p99 = last["planner_p99_ms"]
    p99_text = "-" if p99 is None else f"{p99:.2f}"
    return (
        f"| {planner} | {n_aircraft} + 1 "
        f"| {median:.2f} (min {min(walls):.2f}, max {max(walls):.2f}) "
        f"| {speedup:.1f}x | {verdict} | {cpu:.2f} | {last['gcs_compute_s']:.2f} | {p99_text} |"
    )


def _phases_line(phases: dict[str, dict[str, float]]) -> str:
    """Where each process of a split run spent its ticks, as one line."""
    parts = []
    for process, label in (("run", "this process"), ("worker", "worker")):
        seconds = phases.get(process, {})
        parts.append(f"{label}: " + ", ".join(f"{k} {v:.2f} s" for k, v in seconds.items()))
    return "; ".join(parts)


def _by_tick_table(by_tick: dict[str, dict[str, float]], tick_s: float) -> str:
    """This process's phases (s over the run) by the tick's place in its second, one row per
    phase: where the waits and the heavy ticks fall (JSON keys are strings)."""
    ticks = sorted({int(k) for seconds in by_tick.values() for k in seconds})
    head = "".join(f"{t * tick_s:6.2f}" for t in ticks)
    lines = [f"{'':19s}{'phase / tick at x.':>20s}{head}"]
    for phase, seconds in by_tick.items():
        cells = "".join(f"{seconds.get(str(t), 0.0):6.2f}" for t in ticks)
        lines.append(f"{'':19s}{phase:>20s}{cells}")
    return "\n".join(lines)


def _one_run(args: argparse.Namespace, planner: str, n_aircraft: int) -> dict[str, Any]:
    from ridsafe.tools.analysis.metrics import compute_metrics  # noqa: PLC0415 (not timed)
    from ridsafe.tools.run import lockstep  # noqa: PLC0415
    from ridsafe.tools.run.scenario import load_scenario_file, with_aircraft  # noqa: PLC0415

    logging.basicConfig(level=logging.ERROR)
    loaded = with_aircraft(load_scenario_file(), n_aircraft)
    loaded = dataclasses.replace(
        loaded, scenario=dataclasses.replace(loaded.scenario, duration_s=args.duration)
    )
    if args.tick is not None:
        loaded = dataclasses.replace(
            loaded, run=dataclasses.replace(loaded.run, lockstep_tick_s=args.tick)
        )
    with tempfile.TemporaryDirectory() as tmp:
        start, cpu_start = time.perf_counter(), _cpu_s()
        split = False if args.serial else None  # None: as `ridsafe run` decides
        result = lockstep.run_lockstep(loaded, planner, Path(tmp) / "run.mcap", split=split)
        wall, cpu = time.perf_counter() - start, _cpu_s() - cpu_start
        metrics = compute_metrics(result.log_path)
    return {
        "wall_s": wall,
        "cpu_s": cpu,
        "build_s": result.build_s,
        "sim_s": result.sim_time_s,
        "tick_s": loaded.run.lockstep_tick_s,
        "gcs_compute_s": metrics["gcs_compute_s"],
        "planner_p99_ms": metrics["planner_decision_p99_ms"],
        "phases": result.phase_times_s,  # None in one process
        "phases_by_tick": result.phase_times_by_tick_s,
    }


def _cpu_s() -> float:
    """CPU time of this process and of its children that have ended (s)."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


if __name__ == "__main__":
    main()
