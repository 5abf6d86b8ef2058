"""Run a GCS pipeline over synthetic traffic (``traffic.py``) and measure it.

What ``bench/bench_gcs.py`` and the GCS tests report: detection delay (from the spoofer's
first claim heard by 4 receivers to its alert), false alerts on benign aircraft, and, over
the spoofer's regions, containment of its true position (``ridsafe.common.ellipsoid``),
NEES, RMSE (3D and horizontal), and compute per cycle (``step`` timed from outside, so a
wrapping pipeline's own work counts: ``calibration.pipeline.make_pipeline``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ridsafe.common.ellipsoid import mahalanobis2
from ridsafe.common.messages import AlertState, RidsafeDetector
from ridsafe.gcs.pipeline import EstimationPipeline
from ridsafe.gcs.pipeline_api import CycleOutput, DetectorResult, GcsPipeline
from ridsafe.gcs.pipeline_config import PipelineConfig
from ridsafe.gcs.synthetic.traffic import CYCLE_S, SPOOFER_ID, Traffic

__all__ = ["RunMetrics", "run_pipeline"]


@dataclass
class RunMetrics:
    """What one run measured (times in s, distances in m)."""

    first_heard_by_4_s: float = math.nan
    alert_s: float = math.nan
    alert_detector: RidsafeDetector | None = None
    first_region_s: float = math.nan
    false_alerts: int = 0
    containment: list[bool] = field(default_factory=list)
    errors_m: list[float] = field(default_factory=list)
    errors_h_m: list[float] = field(default_factory=list)
    nees: list[float] = field(default_factory=list)
    compute_s: list[float] = field(default_factory=list)
    results: list[tuple[bool, DetectorResult]] = field(default_factory=list)

    @property
    def delay_s(self) -> float:
        return self.alert_s - self.first_heard_by_4_s

    @property
    def containment_rate(self) -> float:
        return float(np.mean(self.containment)) if self.containment else math.nan

    @property
    def rmse_m(self) -> float:
        return float(np.sqrt(np.mean(np.square(self.errors_m)))) if self.errors_m else math.nan

    @property
    def rmse_h_m(self) -> float:
        e = self.errors_h_m
        return float(np.sqrt(np.mean(np.square(e)))) if e else math.nan


def run_pipeline(
    traffic: Traffic,
    config: PipelineConfig,
    keep_results: bool = False,
    on_cycle: Callable[[float, CycleOutput], None] | None = None,
    scored_from_s: float = -math.inf,
    make: Callable[[PipelineConfig], GcsPipeline] = EstimationPipeline,
) -> RunMetrics:
    """Drive a fresh pipeline ``make(config)`` over ``traffic`` cycle by cycle and measure it
    (the spoofer's regions from ``scored_from_s`` on: containment, NEES, errors). The
    default is the estimation pipeline alone, whatever ``config.calibration`` says."""
    pipeline = make(config)
    metrics = RunMetrics()
    n_cycles = round(traffic.scene.duration_s / CYCLE_S)
    for k in range(1, n_cycles + 1):
        now = round(k * CYCLE_S, 6)
        claims = traffic.cycles.get(now, [])
        for claim in claims:
            if (
                claim.uas_id == SPOOFER_ID
                and claim.n_receivers >= 4
                and math.isnan(metrics.first_heard_by_4_s)
            ):
                metrics.first_heard_by_4_s = claim.t_s
        start = time.perf_counter()
        out = pipeline.step(now, claims)
        metrics.compute_s.append(time.perf_counter() - start)
        _score(traffic, now, out, metrics, keep_results, scored_from_s)
        if on_cycle is not None:
            on_cycle(now, out)
    return metrics


def _score(
    traffic: Traffic,
    now: float,
    out: CycleOutput,
    metrics: RunMetrics,
    keep: bool,
    scored_from_s: float,
) -> None:
    for change in out.alert_changes:
        if change.state is not AlertState.RAISED:
            continue
        if change.uas_id == SPOOFER_ID and math.isnan(metrics.alert_s):
            metrics.alert_s, metrics.alert_detector = now, change.detector
        elif change.uas_id != SPOOFER_ID:
            metrics.false_alerts += 1
    if keep:
        metrics.results.extend((r.uas_id == SPOOFER_ID, r) for r in out.detector_results)
    truth = traffic.spoofer_path.at(now)[0] if traffic.scene.with_spoofer else None
    for region in out.regions:
        if region.uas_id != SPOOFER_ID or truth is None:
            continue
        if math.isnan(metrics.first_region_s):
            metrics.first_region_s = now
        if now < scored_from_s:
            continue
        d = truth - region.center_enu_m
        m2 = float(mahalanobis2(d, region.cov_enu_m2))
        metrics.containment.append(m2 <= region.chi2_threshold)
        metrics.nees.append(m2)
        metrics.errors_m.append(float(np.linalg.norm(d)))
        metrics.errors_h_m.append(float(np.linalg.norm(d[:2])))
