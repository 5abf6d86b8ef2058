"""A spoofer hovering low over parked aircraft (issue 16: a pursuer waits over its target's
pad while the take-off is held) stays inside its region once the Gaussian sum knows where the
ground is (``pipeline.rssi_filter.ground_z_enu_m``, ``localisation/gaussian_sum.py``).

Receivers on the ground hear a transmitter at height h and at -h alike; without the ground the
estimate settled a few metres below it, between the two mirror images, with a tight
covariance. Oracle: the true path against each published region's chi-square ellipsoid.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ridsafe.gcs.localisation.gaussian_sum import mirror_above_ground
from ridsafe.gcs.pipeline_config import (
    ForcedAlertConfig,
    GroundTransmitterConfig,
    PipelineConfig,
)
from ridsafe.gcs.synthetic.evaluate import run_pipeline
from ridsafe.gcs.synthetic.traffic import SPOOFER_ID, Path, Scene, make_traffic
from ridsafe.gcs.tracking.imm import Gaussian, ImmState
from ridsafe.tools.run.scenario import REPO_ROOT, load_scenario_file

DURATION_S = 100.0
HOVER_ENU_M = np.array([435.0, -380.0, 10.0])
SCORED_FROM_S = 40.0  # 10 s after the spoofer has come down to hover


def test_the_mirror_reflects_only_the_hypotheses_below_the_ground() -> None:
    rng = np.random.default_rng(1)
    modes = []
    for n in (7, 10):  # CV (position, velocity, power) and CA order
        A = rng.normal(size=(2, n, n))
        modes.append(Gaussian(rng.normal(size=(2, n)), A @ A.transpose(0, 2, 1) + np.eye(n)))
    modes[0].x[:, 2] = (-4.0, 30.0)
    modes[1].x[:, 2] = (-6.0, 30.0)
    state = ImmState(tuple(modes), np.array([[0.7, 0.3], [0.5, 0.5]]), 3.0)
    below = np.array([True, False])
    out = mirror_above_ground(state, below, 1.5)
    for before, after in zip(state.modes, out.modes, strict=True):
        n = before.x.shape[1]
        flipped = [2, 5, 8][: 3 if n == 10 else 2]
        sign = np.ones(n)
        sign[flipped] = -1.0
        expected_x = before.x[0] * sign
        expected_x[2] += 3.0
        np.testing.assert_allclose(after.x[0], expected_x)
        np.testing.assert_allclose(after.P[0], before.P[0] * np.outer(sign, sign))
        assert after.x[0, -1] == before.x[0, -1]  # the transmit power is not a height
        np.testing.assert_array_equal(after.x[1], before.x[1])
        np.testing.assert_array_equal(after.P[1], before.P[1])
    assert out.modes[0].x[0, 2] == pytest.approx(7.0) and out.modes[1].x[0, 2] == pytest.approx(9.0)
    twice = mirror_above_ground(out, below, 1.5)
    for before, back in zip(state.modes, twice.modes, strict=True):
        np.testing.assert_allclose(back.x, before.x)
        np.testing.assert_allclose(back.P, before.P)


def _hover_path() -> Path:
    """From 100 m east and north, 46 m higher, down to 10 m over the pad in 30 s; then hover."""
    t_s = np.arange(0.0, DURATION_S + 2.5, 0.25)
    start = HOVER_ENU_M + np.array([100.0, 100.0, 46.0])
    frac = np.clip(t_s / 30.0, 0.0, 1.0)[:, None]
    return Path(t_s, start + frac * (HOVER_ENU_M - start))


def _containment(seed: int, parked: int, ground_z_enu_m: float | None) -> float:
    pipeline = load_scenario_file(REPO_ROOT / "configs" / "adversaries.yaml").pipeline
    cfg: PipelineConfig = dataclasses.replace(
        pipeline,
        rssi_filter=dataclasses.replace(pipeline.rssi_filter, ground_z_enu_m=ground_z_enu_m),
        ghosts=GroundTransmitterConfig(),  # needs the ground; its claim hovers: no ghost anyway
        forced_alert=ForcedAlertConfig(enabled=True, uas_id=SPOOFER_ID, time_s=2.0),
    )
    pads = tuple((435.0 + 8.0 * k, -380.0 - 6.0 * k, 0.0) for k in range(parked))
    scene = Scene(seed=seed, n_receivers=14, duration_s=DURATION_S, parked_receivers_enu_m=pads)
    metrics = run_pipeline(make_traffic(scene, _hover_path()), cfg, scored_from_s=SCORED_FROM_S)
    assert len(metrics.containment) > 0.9 * (DURATION_S - SCORED_FROM_S) / 0.25
    return metrics.containment_rate


@pytest.mark.slow
def test_a_spoofer_hovering_over_parked_aircraft_stays_in_its_region_with_the_ground() -> None:
    """14 airborne receivers and 1 or 3 parked under the spoofer, seeds 0-3."""
    cases = [(seed, parked) for parked in (1, 3) for seed in range(4)]
    with_ground = [_containment(s, k, 0.0) for s, k in cases]
    without = [_containment(s, k, None) for s, k in cases]
    assert np.mean(with_ground) >= 0.95 and min(with_ground) >= 0.9
    # The failure the ground removes: with three parked receivers the estimate falls into the
    # mirror image below them on some seeds (two of four at about 0.5).
    assert min(without) < 0.6
