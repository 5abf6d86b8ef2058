"""Benchmark: the GCS pipeline's cost per update inside a lockstep run, against the same
claims replayed in a process that runs nothing else.

    python bench/bench_gcs_replay.py [--config configs/paper.yaml] [--aircraft 64]
                                     [--seed 0] [--duration S] [--repeat 3] [--set KEY=VALUE]

(``--set pipeline.track_claim_cost=1``: the work bound before a track update weighed more.)

One lockstep run (aware planner, nothing logged) with the GCS's pipeline wrapped: each
cycle's claims are kept and its ``step`` is timed in the run. Then the same claims go
through a fresh pipeline of the same configuration ``--repeat`` times in this process, each
cycle timed; per cycle the median over the repeats. Printed both ways: p50, p90, p99 and
mean per update, and the ratio. The difference is what the run's other cores cost the GCS:
the sim and the companions run in the same process between two GCS cycles and leave the
caches cold. The replay is where to profile the pipeline itself.

Only the pipeline's ``step`` is replayed. The GCS's ``compute_ms`` (metric
``gcs_update_p99_ms``) also counts sending the regions to every peer. The step is printed by
the cycles' kind: those given no new transmission (the work bound's waiting claims), one
(the spoofer's, whose broadcasts are not in step with the fleet's) or more (the fleet's,
whose broadcasts are). Building the claims (``ingest.close_due``) is timed too: the GCS
closes a transmission at the first step after its window, between the cycles, and the next
cycle takes it; printed over the steps that closed any.
"""

from __future__ import annotations

import os

# As the ridsafe command line does (ridsafe/tools/cli/entry_point.py): no BLAS worker threads.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import gc  # noqa: E402
import logging  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable, Sequence  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ridsafe.common.config import parse_override  # noqa: E402
from ridsafe.common.logsink import NullSink  # noqa: E402
from ridsafe.common.runner import freeze_startup_objects  # noqa: E402
from ridsafe.gcs.calibration.pipeline import make_pipeline  # noqa: E402
from ridsafe.gcs.pipeline_api import CycleOutput, GcsPipeline, ObservedClaim  # noqa: E402
from ridsafe.tools.run.lockstep import build  # noqa: E402
from ridsafe.tools.run.scenario import REPO_ROOT, load_scenario_file, with_aircraft  # noqa: E402

Cycle = tuple[float, list[ObservedClaim]]


class _Recording:
    """The GCS's pipeline, its claims kept and its ``step`` timed."""

    def __init__(self, inner: GcsPipeline) -> None:
        self.inner = inner
        self.cycles: list[Cycle] = []
        self.step_s: list[float] = []

    def step(self, now_s: float, claims: Sequence[ObservedClaim]) -> CycleOutput:
        start = time.perf_counter()
        out = self.inner.step(now_s, claims)
        self.step_s.append(time.perf_counter() - start)
        self.cycles.append((now_s, list(claims)))
        return out


class _TimedClosing:
    """The GCS ingest's ``close_due``, timed, with how many transmissions each call closed
    (one call per step of the GCS)."""

    def __init__(self, close_due: Callable[[float], list[ObservedClaim]]) -> None:
        self.close_due = close_due
        self.closed: list[int] = []
        self.close_s: list[float] = []

    def __call__(self, now_s: float) -> list[ObservedClaim]:
        start = time.perf_counter()
        claims = self.close_due(now_s)
        self.close_s.append(time.perf_counter() - start)
        self.closed.append(len(claims))
        return claims

    def summary(self) -> str:
        """Building the claims, over the steps that closed any."""
        closed = np.asarray(self.closed)
        picked = closed > 0
        if not picked.any():
            return "    building the claims: no step closed any"
        ms = np.asarray(self.close_s)[picked] * 1e3
        return (
            f"    building the claims, between the cycles ({picked.sum()} steps closed "
            f"{closed[picked].mean():.1f} on average): mean {ms.mean():.3f} ms "
            f"p99 {np.percentile(ms, 99):.3f} ms"
        )


def _by_cycle_kind(new_claims: np.ndarray, step_s: np.ndarray) -> list[str]:
    """Per kind of cycle (new transmissions it was given): the step, in the run."""
    step_ms = step_s * 1e3
    lines = []
    for kind, picked in (
        ("none", new_claims == 0), ("one", new_claims == 1), ("two or more", new_claims >= 2)
    ):  # fmt: skip
        if not picked.any():
            continue
        s = step_ms[picked]
        lines.append(
            f"    given {kind} ({picked.sum()} cycles, {new_claims[picked].mean():.1f} new): "
            f"step mean {s.mean():.3f} ms p99 {np.percentile(s, 99):.3f} ms"
        )
    return lines


def _summary(step_s: np.ndarray) -> str:
    ms = step_s * 1e3
    p50, p90, p99 = np.percentile(ms, [50, 90, 99])
    return f"p50 {p50:.3f} ms  p90 {p90:.3f} ms  p99 {p99:.3f} ms  mean {ms.mean():.3f} ms"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", type=Path, default=REPO_ROOT / "configs" / "paper.yaml")
    parser.add_argument("--aircraft", type=int, default=64)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--duration", type=float, default=120.0)
    parser.add_argument("--repeat", type=int, default=3, help="replays of the claims")
    parser.add_argument(
        "--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
        help="override a config value, as ridsafe run --set",
    )  # fmt: skip
    args = parser.parse_args()
    if args.repeat < 1:
        parser.error("--repeat: must be >= 1")
    logging.basicConfig(level=logging.ERROR)
    loaded = load_scenario_file(args.config, dict(map(parse_override, args.overrides)))
    scenario = dataclasses.replace(loaded.scenario, seed=args.seed, duration_s=args.duration)
    loaded = with_aircraft(dataclasses.replace(loaded, scenario=scenario), args.aircraft)

    run = build(loaded, "aware", NullSink())
    recording = _Recording(run.gcs.pipeline)
    run.gcs.pipeline = recording
    closing = _TimedClosing(run.gcs.ingest.close_due)
    run.gcs.ingest.close_due = closing  # type: ignore[method-assign]
    freeze_startup_objects()  # as every run does before its loop (tools/run/lockstep.py)
    print(f"{args.config.name}, {args.aircraft} aircraft, seed {args.seed}: flying ...", flush=True)
    while run.t_s < args.duration - 1e-9:
        run.step()
    run.finish()

    gc.collect()
    replays = []
    for _ in range(args.repeat):
        pipeline = make_pipeline(loaded.pipeline)
        step_s = []
        for now_s, claims in recording.cycles:
            start = time.perf_counter()
            pipeline.step(now_s, claims)
            step_s.append(time.perf_counter() - start)
        replays.append(step_s)
    replayed = np.median(np.array(replays), axis=0)
    in_run = np.asarray(recording.step_s)
    print(f"  in the run ({len(in_run)} updates): {_summary(in_run)}")
    new_claims = np.array([len(claims) for _, claims in recording.cycles])
    print("\n".join(_by_cycle_kind(new_claims, in_run)))
    print(closing.summary())
    print(f"  replayed alone (median of {args.repeat}): {_summary(replayed)}")
    ratio_p99 = np.percentile(in_run, 99) / np.percentile(replayed, 99)
    print(
        f"  in the run / replayed: mean {in_run.mean() / replayed.mean():.2f}, p99 {ratio_p99:.2f}"
    )


if __name__ == "__main__":
    main()
