"""An altitude the receptions cannot tell apart from the leading one keeps the spoofer in its
region (``pipeline.rssi_filter.weight_memory_s``, ``localisation/gaussian_sum.py``).

The failure it reproduces: eight receivers cruising at 30-100 m, mostly below the spoofer at
60 m, hear it and its mirror image above them alike; under plain Bayes the Gaussian sum kept
the image (100 m) at weight 0.9 and the right altitude at 0.1 or at the respawn's 1e-3, and the
region missed the spoofer for most of a minute. Oracle: the true path against each published
region's chi-square ellipsoid (``gcs/synthetic/evaluate.py``).
"""

from __future__ import annotations

import dataclasses

import pytest

from ridsafe.gcs.pipeline_config import ForcedAlertConfig, PipelineConfig
from ridsafe.gcs.synthetic.evaluate import run_pipeline
from ridsafe.gcs.synthetic.traffic import SPOOFER_ID, Scene, make_traffic

SCORED_FROM_S = 12.0  # the track has settled (the forced alert is at 2 s)


def _containment(seed: int, weight_memory_s: float) -> float:
    base = PipelineConfig()
    config = dataclasses.replace(
        base,
        rssi_filter=dataclasses.replace(base.rssi_filter, weight_memory_s=weight_memory_s),
        forced_alert=ForcedAlertConfig(enabled=True, uas_id=SPOOFER_ID, time_s=2.0),
    )
    traffic = make_traffic(Scene(seed=seed, n_receivers=8, duration_s=90.0))
    return run_pipeline(traffic, config, scored_from_s=SCORED_FROM_S).containment_rate


@pytest.mark.slow
def test_the_mirror_altitude_does_not_hold_the_region_off_the_spoofer() -> None:
    default = PipelineConfig().rssi_filter.weight_memory_s
    assert default > 0.0
    # measured: 0.770 with plain Bayes, 1.000 with the default 5 s
    assert _containment(7, 0.0) < 0.8  # the failure
    assert _containment(7, default) >= 0.95
    # and the seeds that were fine stay fine (0.974, 1.0, 1.0, 0.952 both ways)
    for seed in (0, 1, 2, 9):
        assert _containment(seed, default) >= 0.95
