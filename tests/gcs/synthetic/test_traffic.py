"""The synthetic traffic generator: seeded, heard through the one path-loss model
(``common.pathloss``), claims honest except the spoofer's offset, each claim delivered at
the first GCS cycle after its grouping lag."""

from __future__ import annotations

import math

import numpy as np

from ridsafe.common.pathloss import received_power_dbm
from ridsafe.gcs.synthetic.traffic import CYCLE_S, SPOOFER_ID, Scene, Traffic, make_traffic


def test_a_scene_is_the_same_traffic_every_time() -> None:
    a, b = (make_traffic(Scene(seed=4, n_receivers=5, duration_s=10.0)) for _ in range(2))
    assert a.cycles.keys() == b.cycles.keys()
    for t, claims in a.cycles.items():
        for x, y in zip(claims, b.cycles[t], strict=True):
            assert (x.uas_id, x.rid_timestamp_s) == (y.uas_id, y.rid_timestamp_s)
            np.testing.assert_array_equal(x.rssi_dbm, y.rssi_dbm)
            np.testing.assert_array_equal(x.rx_p_enu_m, y.rx_p_enu_m)
    other = make_traffic(Scene(seed=5, n_receivers=5, duration_s=10.0))
    assert not np.array_equal(_all_rssi(a), _all_rssi(other))


def _all_rssi(traffic: Traffic) -> np.ndarray:
    return np.concatenate([c.rssi_dbm for cs in traffic.cycles.values() for c in cs])


def test_noise_free_rssi_is_the_path_loss_model_and_claims_are_the_truth() -> None:
    scene = Scene(seed=1, n_receivers=6, duration_s=12.0, sigma_db=0.0, spoofer_tx_power_dbm=14.0)
    traffic = make_traffic(scene)
    offset = np.asarray(scene.spoofer_offset_enu_m)
    checked = 0
    for claims in traffic.cycles.values():
        for claim in claims:
            sender = traffic.ids.index(claim.uas_id)
            truth = np.vstack([path.at(claim.rid_timestamp_s) for path in traffic.paths])
            rx = claim.rx_sysid - 1
            assert sender not in rx.tolist()
            np.testing.assert_array_equal(claim.rx_p_enu_m, truth[rx])
            power = scene.spoofer_tx_power_dbm if claim.uas_id == SPOOFER_ID else 20.0
            distance = np.linalg.norm(truth[rx] - truth[sender], axis=1)
            np.testing.assert_array_equal(claim.rssi_dbm, received_power_dbm(power, distance))
            assert np.all(claim.rssi_dbm >= scene.sensitivity_dbm)
            lie = offset if claim.uas_id == SPOOFER_ID else np.zeros(3)
            np.testing.assert_allclose(claim.claimed_p_enu_m, truth[sender] + lie, atol=1e-9)
            checked += 1
    assert checked > 50


def test_each_claim_arrives_at_the_first_cycle_after_the_grouping_lag() -> None:
    scene = Scene(seed=2, n_receivers=4, duration_s=8.0)
    traffic = make_traffic(scene)
    for cycle, claims in traffic.cycles.items():
        assert math.isclose(cycle / CYCLE_S, round(cycle / CYCLE_S), abs_tol=1e-9)
        for claim in claims:
            assert cycle - CYCLE_S < claim.t_s + scene.close_lag_s <= cycle + 1e-9
