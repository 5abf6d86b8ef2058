"""Benchmark (not a test): GCS pipeline compute per 0.25 s update, and the Monte-Carlo sweep
behind the estimator choice.

Default: compute per update (p50/p99/max) with 16, 32 and 64 benign aircraft + 1 spoofer
(``--aircraft``), 120 s of seeded synthetic traffic (``ridsafe/gcs/synthetic``, the sim radio's
model at 1 dB), random broadcast phases and the worst case of all phases aligned (every
aircraft's claim in one cycle, as in the lockstep runs). Each case is timed for the pipeline
a GCS runs by default (``make_pipeline``: the channel check of ``calibration.enabled: auto``
around the estimation pipeline, timed from outside its ``step``) and, on the line after it,
for the estimation pipeline alone (``calibration.enabled: false``). Target p99 <= 2 ms at
every size; each line prints p99 / target. 32 and 64 aircraft run a third of the seeds.

``--mc``: per receiver count (4, 8, 16) and start (receivers airborne, or at the default
scenario's depots), over ``--seeds`` seeds:

- detection with the real detectors (no forced alert): delay from the spoofer's first
  broadcast heard by 4 aircraft, false alerts on benign aircraft per aircraft-hour, per
  transmission ROC AUC of each detector;
- localisation with the alert forced at 5 s (the paper's protocol, so estimators are compared
  over the same cycles): containment at alpha = 0.05 (mean and min over runs), RMSE and
  horizontal RMSE (mean over runs), for our RSSI Gaussian-sum IMM and the paper's NLLS -> IMM
  (Jacobian fix covariance; and the paper's fixed R = 400 I / 50 I).

Run: ``.venv/bin/python bench/bench_gcs.py [--mc] [--seeds 30]``

Each compute line also says how many full (generation 2) garbage collections ran meanwhile
and the longest pause: one walks every object made since the start (the apps, like this
script, freeze what they built before their loop, which a collection then skips; without
that a full collection took ~50 ms) and, when it lands in an update, sets that update's
time (the max). It is reported, not excluded.

BLAS threads: the pipeline's matrices are tiny; OpenBLAS's worker threads only add latency,
and on a loaded 2-core machine a call that waits for a preempted worker stalls a whole
scheduler tick (4 ms). This script sets ``OPENBLAS_NUM_THREADS=1`` unless the environment
already says otherwise; a GCS process should do the same before importing numpy.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import gc
import math
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ridsafe.common.config import with_overrides
from ridsafe.common.messages import RidsafeDetector
from ridsafe.gcs.calibration.pipeline import make_pipeline
from ridsafe.gcs.pipeline import EstimationPipeline
from ridsafe.gcs.pipeline_config import ForcedAlertConfig, PipelineConfig
from ridsafe.gcs.synthetic.evaluate import RunMetrics, run_pipeline
from ridsafe.gcs.synthetic.traffic import SPOOFER_ID, Scene, make_traffic

#: The GCS update's p99 target (ms), at every fleet size (issue 18: 64 aircraft).
TARGET_P99_MS = 2.0
FORCED = ForcedAlertConfig(enabled=True, uas_id=SPOOFER_ID, time_s=5.0)
ESTIMATORS: dict[str, dict[str, object]] = {
    "rssi_imm (ours, default)": {},
    "nlls_imm (paper, Jacobian R)": {"estimator": "nlls_imm"},
    "nlls_imm (paper, R 400/50)": {"estimator": "nlls_imm", "imm.measurement_covariance": "paper"},
}


def _percentiles(samples: list[float]) -> str:
    ms = np.asarray(samples) * 1e3
    return (
        f"p50 {np.percentile(ms, 50):.3f} ms  p99 {np.percentile(ms, 99):.3f} ms  "
        f"max {ms.max():.3f} ms  ({ms.size} updates)"
    )


class _FullCollections:
    """Python's full (generation 2) garbage collections and their pauses while installed:
    one can land inside a timed update and set its max (it walks every tracked object of
    the process, this script's pre-generated traffic included). Reported, not excluded."""

    def __init__(self) -> None:
        self.pauses_s: list[float] = []
        self._start = 0.0
        gc.callbacks.append(self._on_gc)

    def _on_gc(self, phase: str, info: dict[str, int]) -> None:
        if info["generation"] != 2:
            return
        if phase == "start":
            self._start = time.perf_counter()
        else:
            self.pauses_s.append(time.perf_counter() - self._start)

    def close(self) -> str:
        gc.callbacks.remove(self._on_gc)
        if not self.pauses_s:
            return "no full garbage collection"
        longest = max(self.pauses_s) * 1e3
        return f"{len(self.pauses_s)} full garbage collection(s), longest {longest:.1f} ms"


def bench_compute(seeds: int, aircraft: list[int]) -> None:
    EstimationPipeline()  # load the compiled kernels once, as a GCS does at start
    gc.collect()
    gc.freeze()  # and take them out of the collector's reach (runtime.wait_for_start)
    for n in aircraft:
        n_seeds = seeds if n <= 16 else max(1, seeds // 3)  # large N: fewer, longer runs
        for aligned in (False, True):
            for start in ("airborne", "depots"):
                _bench_case(n, n_seeds, start, aligned)


#: The pipelines timed per case: the GCS's default, then the estimation pipeline alone.
PIPELINES = (
    ("default", PipelineConfig()),
    ("cal. off", with_overrides(PipelineConfig(), {"calibration.enabled": False})),
)


def _bench_case(n: int, seeds: int, start: str, aligned: bool) -> None:
    scenes = [
        Scene(seed=seed, n_receivers=n, start=start, aligned_phases=aligned)  # type: ignore[arg-type]
        for seed in range(seeds)
    ]
    for name, config in PIPELINES:
        samples: list[float] = []
        per_run: list[float] = []
        collections = _FullCollections()
        for scene in scenes:
            compute = run_pipeline(make_traffic(scene), config, make=make_pipeline).compute_s
            samples += compute
            per_run.append(float(np.percentile(compute, 99)))
        phases = "aligned phases" if aligned else "random phases "
        p99_ms = float(np.percentile(samples, 99)) * 1e3
        print(
            f"{n:2d} aircraft + spoofer, {start:8s}, {phases}, {name:8s}: "
            f"{_percentiles(samples)}; p99 / target {p99_ms / TARGET_P99_MS:.2f}; median of "
            f"per-run p99 {np.median(per_run) * 1e3:.3f} ms; {collections.close()}"
        )


def _auc(scores_pos: list[float], scores_neg: list[float]) -> float:
    """Mann-Whitney AUC: P(a spoofer transmission outscores a benign one)."""
    if not scores_pos or not scores_neg:
        return math.nan
    neg = np.sort(np.asarray(scores_neg))
    pos = np.asarray(scores_pos)
    below = np.searchsorted(neg, pos, side="left")
    ties = np.searchsorted(neg, pos, side="right") - below
    return float((below + 0.5 * ties).sum() / (pos.size * neg.size))


def mc_detection(n: int, start: str, seeds: int) -> None:
    delays, hours, false_alerts = [], 0.0, 0
    flagged: dict[RidsafeDetector, int] = defaultdict(int)
    scores: dict[RidsafeDetector, tuple[list[float], list[float]]] = defaultdict(lambda: ([], []))
    for seed in range(seeds):
        traffic = make_traffic(Scene(seed=seed, n_receivers=n, start=start))  # type: ignore[arg-type]
        m = run_pipeline(traffic, PipelineConfig(), keep_results=True)
        delays.append(m.delay_s)
        false_alerts += m.false_alerts
        hours += n * traffic.scene.duration_s / 3600.0
        would_alert: dict[RidsafeDetector, set[str]] = defaultdict(set)
        for spoofer, r in m.results:
            scores[r.detector][0 if spoofer else 1].append(r.statistic / r.threshold)
            if r.decision and not spoofer:
                would_alert[r.detector].add(r.uas_id)
        for det, ids in would_alert.items():
            flagged[det] += len(ids)
    d = np.asarray(delays)
    print(
        f"  detection n={n:2d} {start:8s}: delay median {np.nanmedian(d):.2f} s, "
        f"p90 {np.nanpercentile(d, 90):.2f} s, max {np.nanmax(d):.2f} s, missed "
        f"{int(np.isnan(d).sum())}/{seeds}; false alerts {false_alerts} in {hours:.1f} "
        f"aircraft-h ({false_alerts / hours:.3f}/aircraft-h)"
    )
    for det in sorted(scores):
        pos, neg = scores[det]
        print(
            f"      {det.name:12s} AUC {_auc(pos, neg):.3f}  benign aircraft it would flag: "
            f"{flagged[det]} ({flagged[det] / hours:.3f}/aircraft-h)"
        )


def mc_localisation(n: int, start: str, seeds: int) -> None:
    for name, overrides in ESTIMATORS.items():
        cfg = with_overrides(PipelineConfig(forced_alert=FORCED), overrides)
        runs: list[RunMetrics] = []
        for seed in range(seeds):
            scene = Scene(seed=seed, n_receivers=n, start=start)  # type: ignore[arg-type]
            runs.append(run_pipeline(make_traffic(scene), cfg))
        cont = np.array([r.containment_rate for r in runs])
        rmse = np.array([r.rmse_m for r in runs])
        rmse_h = np.array([r.rmse_h_m for r in runs])
        first = np.array([r.first_region_s for r in runs]) - 5.0
        comp = [c for r in runs for c in r.compute_s]
        print(
            f"  {name:30s} n={n:2d} {start:8s}: containment {np.nanmean(cont):.3f} "
            f"(min {np.nanmin(cont):.3f}), RMSE {np.nanmean(rmse):6.1f} +/- "
            f"{np.nanstd(rmse):5.1f} m,"
            f" horizontal {np.nanmean(rmse_h):5.1f} m, region after {np.nanmedian(first):.2f} s"
            f" (max {np.nanmax(first):.2f}), compute p99 {np.percentile(comp, 99) * 1e3:.2f} ms"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mc", action="store_true", help="run the Monte-Carlo sweep too")
    parser.add_argument("--seeds", type=int, default=30)
    parser.add_argument("--receivers", default="4,8,16")
    parser.add_argument(
        "--aircraft", default="16,32,64", help="fleet sizes of the compute benchmark"
    )
    args = parser.parse_args()
    t0 = time.perf_counter()
    threads = os.environ["OPENBLAS_NUM_THREADS"]
    print(f"GCS compute per 0.25 s update (detection to regions), BLAS threads {threads}:")
    bench_compute(min(args.seeds, 10), [int(n) for n in args.aircraft.split(",")])
    if args.mc:
        counts = [int(c) for c in args.receivers.split(",")]
        print(f"\nMonte-Carlo, {args.seeds} seeds, 120 s, RSSI noise 1 dB, 50 m offset spoofer:")
        for start in ("airborne", "depots"):
            for n in counts:
                mc_detection(n, start, args.seeds)
            for n in counts:
                mc_localisation(n, start, args.seeds)
    print(f"\n(wall time {time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
