"""A spoofer that manoeuvres all the time (issue 16: orbit over a depot, pursuit, waypoints)
keeps its true position inside its unsafe region with the process noise of
``configs/adversaries.yaml``, and did not with the paper's straight-flight noise.

Oracle: the true orbit (``gcs/synthetic/traffic.py`` with a given spoofer path) against each
published region's chi-square ellipsoid (``common/ellipsoid.py``). The failure it reproduces:
16 aircraft, ``--set family.adversaries.preset=orbit``, seeds 0 and 1 of the lockstep family
kept containment 0.86 and 0.63 (the issue asks for >= 0.90): a CV mode of white acceleration
0.05 m^2/s^3 believes the spoofer flies straight and lags the turn by 15-20 m with 4-6 m
standard deviations.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ridsafe.gcs.pipeline_config import ForcedAlertConfig, PipelineConfig
from ridsafe.gcs.synthetic.evaluate import run_pipeline
from ridsafe.gcs.synthetic.traffic import (
    DEPOTS_ENU_M,
    SPOOFER_ID,
    Path,
    Scene,
    Traffic,
    make_traffic,
)
from ridsafe.tools.run.scenario import REPO_ROOT, load_scenario_file

DURATION_S = 90.0
SCORED_FROM_S = 12.0  # the track has settled (the forced alert is at 2 s)


def _orbit(centre_enu_m: np.ndarray, radius_m: float, speed_m_s: float) -> Path:
    t_s = np.arange(0.0, DURATION_S + 2.5, 0.25)
    angle = t_s * speed_m_s / radius_m
    p = centre_enu_m + radius_m * np.column_stack([np.cos(angle), np.sin(angle), 0.0 * t_s])
    return Path(t_s, p)


def _adversaries_pipeline() -> PipelineConfig:
    pipeline = load_scenario_file(REPO_ROOT / "configs" / "adversaries.yaml").pipeline
    forced = ForcedAlertConfig(enabled=True, uas_id=SPOOFER_ID, time_s=2.0)
    return dataclasses.replace(pipeline, forced_alert=forced)


def _containment(traffic: Traffic, cfg: PipelineConfig) -> float:
    metrics = run_pipeline(traffic, cfg, scored_from_s=SCORED_FROM_S)
    assert len(metrics.containment) > 0.9 * (DURATION_S - SCORED_FROM_S) / 0.25
    return metrics.containment_rate


@pytest.mark.slow
def test_an_orbiting_spoofer_stays_inside_its_region_with_the_adversaries_noise() -> None:
    """Radius 60 m at 7 m/s over a depot at 60 m (the family's orbit), 16 aircraft from the
    depots; straight-flight noise on the same traffic for contrast."""
    adversaries = _adversaries_pipeline()
    straight = dataclasses.replace(
        adversaries,
        rssi_filter=dataclasses.replace(adversaries.rssi_filter, q_cv_accel_m2_s3=0.05),
    )
    orbit = _orbit(DEPOTS_ENU_M[2] + np.array([0.0, 0.0, 60.0]), 60.0, 7.0)
    manoeuvre, level = [], []
    for seed in range(4):
        traffic = make_traffic(
            Scene(seed=seed, n_receivers=16, duration_s=DURATION_S, start="depots"), orbit
        )
        manoeuvre.append(_containment(traffic, adversaries))
        level.append(_containment(traffic, straight))
    # measured: 0.96 0.95 0.90 0.97 (straight-flight noise 0.84 0.84 0.81 0.83; before the
    # Gaussian sum's weights forgot old evidence, rssi_filter.weight_memory_s: 0.96 0.87 0.90
    # 0.96 and 0.72 0.66 0.77 0.81)
    print(f"containment {np.round(manoeuvre, 3)} (straight-flight noise {np.round(level, 3)})")
    assert np.mean(manoeuvre) >= 0.90 and min(manoeuvre) >= 0.85
    assert np.mean(level) < 0.85  # straight-flight noise misses the 0.90


def test_a_given_spoofer_path_replaces_the_line_and_keeps_the_rest_of_the_traffic() -> None:
    scene = Scene(seed=3, n_receivers=4, duration_s=10.0)
    line = make_traffic(scene)
    hover = Path(np.array([0.0, 12.0]), np.array([[10.0, 20.0, 60.0], [10.0, 20.0, 60.0]]))
    other = make_traffic(scene, hover)
    assert other.spoofer_path is hover
    for a, b in zip(line.paths[:-1], other.paths[:-1], strict=True):
        np.testing.assert_array_equal(a.p_enu_m, b.p_enu_m)
    heard = {t: [c.uas_id for c in cs] for t, cs in line.cycles.items()}
    heard_other = {t: [c.uas_id for c in cs] for t, cs in other.cycles.items()}
    assert heard.keys() == heard_other.keys()
    benign = [c for cs in line.cycles.values() for c in cs if c.uas_id != SPOOFER_ID]
    benign_other = [c for cs in other.cycles.values() for c in cs if c.uas_id != SPOOFER_ID]
    assert [c.rid_timestamp_s for c in benign] == [c.rid_timestamp_s for c in benign_other]
