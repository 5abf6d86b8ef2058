"""The estimation pipeline end to end on synthetic traffic: alerts (real and forced, once,
cleared on silence), tracks and regions every cycle, both estimators, and the seeded
consistency of the default one (containment near 1 - alpha)."""

from __future__ import annotations

import dataclasses
from typing import Literal

import numpy as np
import pytest
from scipy import stats

from ridsafe.common.messages import AlertState, RidsafeDetector
from ridsafe.common.pathloss import received_power_dbm
from ridsafe.gcs.pipeline import EstimationPipeline
from ridsafe.gcs.pipeline_api import CycleOutput, GcsPipeline, ObservedClaim, readonly, receptions
from ridsafe.gcs.pipeline_config import ForcedAlertConfig, PipelineConfig
from ridsafe.gcs.synthetic.evaluate import run_pipeline
from ridsafe.gcs.synthetic.traffic import CYCLE_S, SPOOFER_ID, Scene, Traffic, make_traffic

N_DETECTORS = 5


def _run(
    traffic: Traffic, cfg: PipelineConfig, until_s: float | None = None
) -> list[tuple[float, CycleOutput]]:
    pipeline = EstimationPipeline(cfg)
    end = traffic.scene.duration_s if until_s is None else until_s
    out = []
    for k in range(1, round(end / CYCLE_S) + 1):
        now = round(k * CYCLE_S, 6)
        out.append((now, pipeline.step(now, traffic.cycles.get(now, []))))
    return out


def test_is_a_gcs_pipeline() -> None:
    pipeline: GcsPipeline = EstimationPipeline()
    assert pipeline.step(0.25, []) == CycleOutput()


def test_real_detector_alerts_once_then_regions_every_cycle() -> None:
    traffic = make_traffic(Scene(seed=3, n_receivers=12, duration_s=40.0))
    cycles = _run(traffic, PipelineConfig())
    raised = [
        (t, c) for t, out in cycles for c in out.alert_changes if c.state is AlertState.RAISED
    ]
    assert [c.uas_id for _, c in raised] == [SPOOFER_ID]
    _, change = raised[0]
    assert change.detector is not RidsafeDetector.FORCED and change.statistic > change.threshold
    with_region = [t for t, out in cycles if any(r.uas_id == SPOOFER_ID for r in out.regions)]
    assert with_region and with_region == [t for t, _ in cycles if t >= with_region[0]]
    for t, out in cycles:
        for region in out.regions:
            assert region.t_s == t and region.valid_until_s == pytest.approx(t + 1.0)
            assert region.chi2_threshold == pytest.approx(7.8147, abs=1e-4)
        for track in out.tracks:
            assert track.uas_id == SPOOFER_ID
    n_tx = sum(
        1
        for t, claims in traffic.cycles.items()
        if t <= 40.0
        for claim in claims
        if claim.n_receivers >= 3
    )
    assert sum(len(out.detector_results) for _, out in cycles) == N_DETECTORS * n_tx


def test_forced_alert_at_the_configured_time_and_detectors_silent() -> None:
    traffic = make_traffic(Scene(seed=1, n_receivers=8, duration_s=20.0))
    cfg = PipelineConfig(
        forced_alert=ForcedAlertConfig(enabled=True, uas_id=SPOOFER_ID, time_s=5.0)
    )
    cycles = _run(traffic, cfg)
    changes = [(t, c) for t, out in cycles for c in out.alert_changes]
    assert [(t, c.uas_id, c.detector, c.state) for t, c in changes] == [
        (5.0, SPOOFER_ID, RidsafeDetector.FORCED, AlertState.RAISED)
    ]
    first_region = min(t for t, out in cycles if out.regions)
    assert first_region == 5.0


def test_silence_deletes_the_track_and_clears_the_alert() -> None:
    traffic = make_traffic(Scene(seed=2, n_receivers=10, duration_s=35.0))
    for t in list(traffic.cycles):  # the spoofer goes quiet after 20 s
        if t > 20.0:
            traffic.cycles[t] = [claim for claim in traffic.cycles[t] if claim.uas_id != SPOOFER_ID]
    cfg = PipelineConfig(
        forced_alert=ForcedAlertConfig(enabled=True, uas_id=SPOOFER_ID, time_s=2.0)
    )
    cycles = _run(traffic, cfg)
    deleted = [t for t, out in cycles if SPOOFER_ID in out.deleted_tracks]
    cleared = [
        (t, c) for t, out in cycles for c in out.alert_changes if c.state is AlertState.CLEARED
    ]
    last_heard = max(
        claim.t_s
        for claims in traffic.cycles.values()
        for claim in claims
        if claim.uas_id == SPOOFER_ID
    )
    assert len(deleted) == 1 and last_heard + 10.0 < deleted[0] <= last_heard + 10.0 + CYCLE_S
    assert [t for t, _ in cleared] == deleted
    assert not any(out.regions for t, out in cycles if t >= deleted[0])


def test_the_papers_pipeline_is_selectable() -> None:
    traffic = make_traffic(Scene(seed=4, n_receivers=12, duration_s=40.0))
    cfg = PipelineConfig(
        estimator="nlls_imm",
        forced_alert=ForcedAlertConfig(enabled=True, uas_id=SPOOFER_ID, time_s=5.0),
    )
    metrics = run_pipeline(traffic, cfg)
    assert metrics.alert_detector is RidsafeDetector.FORCED
    assert len(metrics.errors_m) > 100 and np.all(np.isfinite(metrics.errors_m))


def test_compute_time_is_kept_every_cycle() -> None:
    traffic = make_traffic(Scene(seed=0, n_receivers=6, duration_s=10.0))
    pipeline = EstimationPipeline()
    for k in range(1, 41):
        pipeline.step(k * CYCLE_S, traffic.cycles.get(round(k * CYCLE_S, 6), []))
    assert len(pipeline.compute_s) == 40 and all(s > 0 for s in pipeline.compute_s)


@pytest.mark.parametrize("start", ["airborne", "depots"])
def test_default_estimator_is_consistent(start: Literal["airborne", "depots"]) -> None:
    """Seeded Monte-Carlo (3 runs of 8 receivers, 1 dB): the ellipsoid holds the spoofer in
    about 1 - alpha of the cycles (pooled rate not below 0.85), the NEES averages near 3 (not
    above its chi-square bound for the pooled cycles at an effective sample size of one per
    10 s), and the position error is tens of metres."""
    contained, nees, errors = [], [], []
    for seed in range(3):
        scene = Scene(seed=seed + 10, n_receivers=8, start=start)
        m = run_pipeline(make_traffic(scene), PipelineConfig())
        contained += m.containment
        nees += m.nees
        errors += m.errors_m
        assert m.false_alerts == 0
    assert np.mean(contained) >= 0.85
    n_eff = len(nees) // 40
    assert np.mean(nees) < stats.chi2.ppf(0.999, 3 * n_eff) / n_eff
    assert np.sqrt(np.mean(np.square(errors))) < 50.0


def test_non_finite_transmissions_are_ignored() -> None:
    traffic = make_traffic(Scene(seed=0, n_receivers=6, duration_s=5.0))
    claim = next(claim for claims in traffic.cycles.values() for claim in claims)
    rssi = claim.rssi_dbm.copy()
    rssi[0] = np.nan
    bad = ObservedClaim(
        claim.uas_id,
        claim.rid_timestamp_s,
        claim.claimed_p_enu_m,
        None,
        claim.rx_sysid,
        claim.rx_p_enu_m,
        claim.rx_t_s,
        readonly(rssi),
    )
    assert EstimationPipeline().step(1.0, [bad]) == CycleOutput()


def _with_grounded_receivers(traffic: Traffic, rng: np.random.Generator) -> Traffic:
    """The spoofer's claims also heard by 4 receivers on the ground (0 m up) whose RSSI is
    20 dB short of free space (a ground reflection's loss)."""
    grounded = np.column_stack((rng.uniform(-400, 400, (4, 2)), np.zeros(4)))
    cycles: dict[float, list[ObservedClaim]] = {}
    for t, claims in traffic.cycles.items():
        out = []
        for heard in claims:
            claim = heard
            if claim.uas_id == SPOOFER_ID:
                true = traffic.spoofer_path.at(claim.t_s)[0]
                d = np.maximum(np.linalg.norm(grounded - true, axis=1), 1.0)
                rssi = received_power_dbm(20.0, d) - 20.0
                claim = ObservedClaim(
                    claim.uas_id,
                    claim.rid_timestamp_s,
                    claim.claimed_p_enu_m,
                    claim.claimed_v_enu_m_s,
                    np.concatenate([claim.rx_sysid, np.arange(101, 105, dtype=np.int64)]),
                    readonly(np.vstack([claim.rx_p_enu_m, grounded])),
                    readonly(np.concatenate([claim.rx_t_s, np.full(4, claim.t_s)])),
                    readonly(np.concatenate([claim.rssi_dbm, rssi])),
                )
            out.append(claim)
        cycles[t] = out
    return Traffic(traffic.scene, traffic.paths, traffic.ids, cycles, traffic.claim_path)


def test_tracks_may_leave_out_receivers_on_the_ground_the_detectors_keep() -> None:
    traffic = _with_grounded_receivers(
        make_traffic(Scene(seed=5, n_receivers=10, duration_s=40.0)), np.random.default_rng(6)
    )
    errors, statistics = {}, {}
    for height in (0.0, 15.0):
        cfg = PipelineConfig()
        cfg = dataclasses.replace(
            cfg, tracks=dataclasses.replace(cfg.tracks, min_receiver_height_m=height)
        )
        cycles = _run(traffic, cfg)
        statistics[height] = [
            (r.detector, r.statistic) for _, out in cycles for r in out.detector_results
        ]
        errors[height] = np.median(
            [
                np.linalg.norm(track.p_enu_m[:2] - traffic.spoofer_path.at(t)[0, :2])
                for t, out in cycles
                for track in out.tracks
            ]
        )
    assert statistics[0.0] == statistics[15.0]  # the detectors heard the same
    assert errors[15.0] < 30.0 < errors[0.0]


def test_a_track_heard_only_by_grounded_receivers_is_still_heard() -> None:
    """Receptions left out of the tracks are still hearing: a transmitter that only the
    grounded receivers hear for longer than ``silence_timeout_s`` keeps its track and alert."""
    traffic = _with_grounded_receivers(
        make_traffic(Scene(seed=5, n_receivers=10, duration_s=40.0)), np.random.default_rng(6)
    )
    only_grounded_from_s = 20.0
    for t, claims in traffic.cycles.items():
        if t >= only_grounded_from_s:
            traffic.cycles[t] = [
                receptions(c, c.rx_p_enu_m[:, 2] < 1.0) if c.uas_id == SPOOFER_ID else c
                for c in claims
            ]
    cfg = PipelineConfig()
    cfg = dataclasses.replace(
        cfg, tracks=dataclasses.replace(cfg.tracks, min_receiver_height_m=15.0)
    )
    assert traffic.scene.duration_s - only_grounded_from_s > cfg.tracks.silence_timeout_s
    cycles = _run(traffic, cfg)
    assert any(t < only_grounded_from_s and out.tracks for t, out in cycles)  # it started
    assert not any(SPOOFER_ID in out.deleted_tracks for _, out in cycles)
    assert [track.uas_id for track in cycles[-1][1].tracks] == [SPOOFER_ID]
