"""Benchmark (not a test): a fuzz campaign of N mutated inputs into each core, then a check
that each still does its job (``ridsafe.tools.fuzz.harness``).

Per core (sim, companion, GCS): a fresh lockstep run of the scenario is warmed up for
``--warm-s`` (its datagrams are the seeds), the core gets ``--inputs`` mutated datagrams
(bytes and field values, CRC and signature recomputed) at the paused time, and the run goes
on clean to the scenario's end. Printed: inputs/s, crashes (exceptions out of ``handle``),
calls over 100 ms, hangs (over 1 s), the slowest call, and whether the core still works.

Run: ``.venv/bin/python bench/bench_fuzz.py [--inputs 1000000] [--cores sim,gcs] [--seed 0]``
Exit status 1 if any core crashed, hung, was slow or stopped working.
"""

from __future__ import annotations

import argparse
import logging
import random
import sys
import time

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
    args = parser.parse_args(argv)
    logging.disable(logging.ERROR)  # the cores log every rejection; the counts are the point
    loaded = load_scenario_file(args.config)
    failed = False
    for core in args.cores.split(","):
        fuzz_run = warm_up(loaded, args.planner, args.warm_s)
        report = fuzz_run.fuzz_core(core, args.inputs, random.Random(args.seed))
        start = time.perf_counter()
        fuzz_run.finish_and_check(report)
        print(_line(report, time.perf_counter() - start), flush=True)
        for crash in report.first_crashes:
            print(f"    crash: {crash}")
        failed |= bool(report.crashes or report.hangs or report.slow_calls)
        failed |= not report.still_works
    return 1 if failed else 0


def _line(report: FuzzReport, check_s: float) -> str:
    return (
        f"{report.core:9s} {report.inputs:>9,d} inputs in {report.seconds:7.1f} s "
        f"({report.inputs_per_s:8,.0f}/s)  crashes {report.crashes}  "
        f"calls >100 ms {report.slow_calls}  hangs {report.hangs}  "
        f"slowest {report.slowest_ms:6.1f} ms  still works: {report.still_works} "
        f"({report.job}; checked in {check_s:.1f} s)"
    )


if __name__ == "__main__":
    sys.exit(main())
