"""Benchmark (not a test): a fuzz campaign of N mutated inputs into each core, then a check
that each still does its job (``ridsafe.tools.fuzz.harness``).

Per core (sim, companion, GCS): a fresh lockstep run of the scenario is warmed up for
``--warm-s`` (its datagrams are the seeds), the core gets ``--inputs`` mutated datagrams
(bytes and field values, CRC and signature recomputed) at the paused time, and the run goes
on clean to the scenario's end. Printed per core: inputs/s, crashes (exceptions out of
``handle``), calls over 100 ms and hangs (over 1 s) of CPU time, the slowest call (CPU and
wall time: on a shared machine the wall time holds waits for a CPU too), and whether the core
still works; with ``--progress N`` also a line every N inputs. ``--batch B`` hands the core
B datagrams per ``handle`` call, as a UDP runner does with what arrived since its last step
(slow calls are then counted per call, which bounds each input's time from above).
``--workers K`` runs the cores' campaigns in K processes at once (one process per core:
each core gets all of its inputs in one instance, so "still works" is judged after the
whole campaign).

Run: ``.venv/bin/python bench/bench_fuzz.py [--inputs 1000000] [--cores sim,gcs] [--seed 0]
[--workers 2]``. Exit status 1 if any core crashed, hung, was slow or stopped working.
"""

from __future__ import annotations

import argparse
import logging
import multiprocessing
import random
import sys
import time
from concurrent.futures import ProcessPoolExecutor

from ridsafe.tools.fuzz.harness import CORES, FuzzReport, warm_up
from ridsafe.tools.run.scenario import load_scenario_file


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config", nargs="?", help="scenario YAML (default configs/default.yaml)")
    parser.add_argument("--inputs", type=int, default=1_000_000, help="mutated inputs per core")
    parser.add_argument("--cores", default=",".join(CORES), help="comma-separated targets")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--warm-s", type=float, default=20.0, help="clean run before fuzzing")
    parser.add_argument("--planner", default="aware")
    parser.add_argument("--workers", type=int, default=1, help="processes, one core each")
    parser.add_argument("--progress", type=int, default=0, help="a line every N inputs")
    parser.add_argument("--batch", type=int, default=1, help="datagrams per handle call")
    args = parser.parse_args(argv)
    if args.workers < 1:
        parser.error(f"--workers must be at least 1, got {args.workers}")
    if args.batch < 1:
        parser.error(f"--batch must be at least 1, got {args.batch}")
    jobs = [(args.config, args.planner, args.warm_s, c, args.inputs, args.seed, args.progress,
             args.batch) for c in args.cores.split(",")]  # fmt: skip
    start = time.perf_counter()
    if args.workers == 1:
        results = [_campaign(*job) for job in jobs]
    else:
        context = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(args.workers, mp_context=context) as pool:
            results = list(pool.map(_campaign, *zip(*jobs, strict=True)))
    failed = False
    print(f"--- summary ({args.workers} workers, {time.perf_counter() - start:.0f} s wall)")
    for report, check_s in results:
        print(_line(report, check_s), flush=True)
        for crash in report.first_crashes:
            print(f"    crash: {crash}")
        for slow in report.first_slow:
            print(f"    slow: {slow}")
        failed |= bool(report.crashes or report.hangs or report.slow_calls)
        failed |= not report.still_works
    return 1 if failed else 0


def _campaign(
    config: str | None,
    planner: str,
    warm_s: float,
    core: str,
    n: int,
    seed: int,
    every: int,
    batch: int,
) -> tuple[FuzzReport, float]:
    """One core's campaign in this process: warm up, fuzz, run on clean and check."""
    logging.disable(logging.ERROR)  # the cores log every rejection; the counts are the point
    fuzz_run = warm_up(load_scenario_file(config), planner, warm_s)
    progress = (lambda r: print(_progress(r), flush=True)) if every > 0 else None
    report = fuzz_run.fuzz_core(core, n, random.Random(seed), progress, max(every, 1), batch)
    start = time.perf_counter()
    fuzz_run.finish_and_check(report)
    check_s = time.perf_counter() - start
    print(_line(report, check_s), flush=True)
    return report, check_s


def _progress(report: FuzzReport) -> str:
    return (
        f"  {report.core:9s} {report.inputs:>9,d} so far ({report.inputs_per_s:,.0f}/s)  "
        f"crashes {report.crashes}  calls >100 ms {report.slow_calls} "
        f"({report.slow_calls_gc} only by gc)  "
        f"hangs {report.hangs}  slowest {report.slowest_ms:.1f} ms CPU "
        f"({report.slowest_wall_ms:.1f} ms wall, {report.slow_calls_wall} calls >100 ms wall)"
    )


def _line(report: FuzzReport, check_s: float) -> str:
    return (
        f"{report.core:9s} {report.inputs:>9,d} inputs in {report.seconds:7.1f} s "
        f"({report.inputs_per_s:8,.0f}/s)  crashes {report.crashes}  "
        f"calls >100 ms {report.slow_calls} ({report.slow_calls_gc} only by gc)  "
        f"hangs {report.hangs}  "
        f"slowest {report.slowest_ms:6.1f} ms CPU  (wall: slowest {report.slowest_wall_ms:.1f} ms, "
        f"{report.slow_calls_wall} calls >100 ms)  still works: {report.still_works} "
        f"({report.job}; checked in {check_s:.1f} s)"
    )


if __name__ == "__main__":
    sys.exit(main())
