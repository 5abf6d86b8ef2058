"""The calibrated alert decision: sliding maximum, cooperative cross-check, empirical null,
localisation inflation from the vouched MLAT statistics, and the pipeline's review hook."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import chdtrc

from ridsafe.common.messages import RidsafeDetector
from ridsafe.gcs.calibration.channel_fit import ChannelEstimate
from ridsafe.gcs.calibration.config import CalibrationConfig
from ridsafe.gcs.calibration.cooperative import CooperativeLabeller
from ridsafe.gcs.calibration.pipeline import CalibratingPipeline
from ridsafe.gcs.calibration.review import CalibratedReview, SlidingMax, SlidingMedian
from ridsafe.gcs.pipeline import EstimationPipeline
from ridsafe.gcs.pipeline_api import DetectorResult, ObservedClaim, airborne_receptions
from ridsafe.gcs.pipeline_config import PipelineConfig
from ridsafe.gcs.synthetic.traffic import CYCLE_S, SPOOFER_ID, Scene, make_traffic
from tests.gcs.claims import free_space_claim

CFG = CalibrationConfig(enabled=True, min_samples=10, min_time_s=0.0, null_min_claims=3)
POSITIONS = {1: [0.0, 0.0, 50.0], 2: [300.0, 0.0, 60.0], 3: [0.0, 400.0, 70.0]}


def _labelled(cfg: CalibrationConfig = CFG) -> CooperativeLabeller:
    lab = CooperativeLabeller(cfg)
    for k in range(5):
        for sysid, p in POSITIONS.items():
            others = {i: q for i, q in POSITIONS.items() if i != sysid}
            lab.observe(free_space_claim(f"RID{sysid}", float(k), p, others))
    return lab


def _stranger(t: float) -> ObservedClaim:
    """An unlabelled serial claiming a place 150 m from every aircraft."""
    return free_space_claim("STRANGER", t, [150.0, 150.0, 60.0], POSITIONS)


def _result(uas_id: str, statistic: float, threshold: float = 6.0) -> DetectorResult:
    return DetectorResult(uas_id, RidsafeDetector.MLAT, statistic, threshold, statistic > threshold)


def test_sliding_max_matches_brute_force() -> None:
    rng = np.random.default_rng(0)
    window = SlidingMax(3.0)
    pushed: list[tuple[float, float]] = []
    for t in np.cumsum(rng.uniform(0.0, 0.7, 200)):
        v = float(rng.normal())
        window.push(float(t), v)
        pushed.append((float(t), v))
        expected = max(x for s, x in pushed if s > t - 3.0)
        assert window.value(float(t)) == expected
    assert SlidingMax(1.0).value(0.0) == 0.0


def test_sliding_median_is_numpys_median_of_the_window() -> None:
    rng = np.random.default_rng(1)
    window = SlidingMedian(3.0)
    pushed: list[tuple[float, float]] = []
    counts = set()
    for t in np.cumsum(rng.uniform(0.0, 0.5, 400)):
        for _ in range(int(rng.integers(0, 3))):  # several at one time, repeats, a NaN
            v = float(rng.choice([rng.normal(), 0.5, np.nan], p=[0.8, 0.15, 0.05]))
            window.push(float(t), v)
            pushed.append((float(t), v))
        inside = [x for s, x in pushed if s > t - 3.0 and not np.isnan(x)]
        counts.add(len(inside) % 2)
        got = window.value(float(t))
        assert got == (float(np.median(inside)) if inside else None)
    assert counts == {0, 1}  # both the middle value and the mean of the two middle ones


def test_labeller_vouches_only_for_claims_where_the_aircraft_is() -> None:
    lab = _labelled()
    others = {i: q for i, q in POSITIONS.items() if i != 1}
    assert lab.vouches(free_space_claim("RID1", 5.0, [10.0, 0.0, 50.0], others))
    # The same serial claimed 100 m from where aircraft 1 reports being: not vouched.
    assert not lab.vouches(free_space_claim("RID1", 5.0, [100.0, 0.0, 50.0], others))
    # An unlabelled serial at aircraft 1's position: not vouched either.
    assert not lab.vouches(free_space_claim("OTHER", 5.0, [0.0, 0.0, 50.0], others))


def test_review_vetoes_vouched_claims_and_raises_the_threshold_for_the_others() -> None:
    lab = _labelled()
    review = CalibratedReview(CFG, lab)
    others = {i: q for i, q in POSITIONS.items() if i != 2}
    # Before the null has seen null_min_claims vouched claims nothing may alert.
    assert not review(_stranger(5.0), (_result("STRANGER", 50.0),))[0].decision
    for k in range(3):  # vouched claims whose MLAT statistic is 10 (over the threshold 6)
        out = review(
            free_space_claim("RID2", 5.0 + k, POSITIONS[2], others), (_result("RID2", 10.0),)
        )
        assert out[0].statistic == 10.0 and not out[0].decision
    assert review.null_statistic(RidsafeDetector.MLAT, 8.0) == 10.0
    # A stranger at 11 beats the nominal threshold but not 1.25 x the null's 10.
    (weak,) = review(_stranger(8.0), (_result("STRANGER", 11.0),))
    assert weak.threshold == pytest.approx(12.5) and not weak.decision
    (strong,) = review(_stranger(8.0), (_result("STRANGER", 13.0),))
    assert strong.decision
    # Once the vouched statistics leave the window the nominal threshold is back.
    late = CFG.null_window_s + 10.0
    (back,) = review(_stranger(late), (_result("STRANGER", 7.0),))
    assert back.threshold == 6.0 and back.decision


def _surprisal(statistic: np.ndarray) -> np.ndarray:
    return np.asarray(-np.log10(chdtrc(3, statistic)), dtype=np.float64)


@pytest.mark.parametrize("scale", [1.0, 4.0])
def test_localisation_inflation_recovers_the_scale_of_chi2_3(scale: float) -> None:
    """Vouched MLAT statistics c * chi2_3 give an inflation near c (1 when the model holds)."""
    lab = _labelled()
    review = CalibratedReview(CFG, lab)
    others = {i: q for i, q in POSITIONS.items() if i != 3}
    rng = np.random.default_rng(1)
    stats = _surprisal(scale * rng.chisquare(3, 600))
    for k, s in enumerate(stats):
        review(
            free_space_claim("RID3", 5.0 + 0.01 * k, POSITIONS[3], others),
            (_result("RID3", float(s)),),
        )
    assert review.localisation_inflation(12.0) == pytest.approx(scale, rel=0.15)


def test_airborne_receptions_drop_grounded_receivers() -> None:
    claim = free_space_claim(
        "X", 0.0, [0.0, 0.0, 60.0], {1: [100.0, 0.0, 0.0], 2: [0.0, 200.0, 50.0]}
    )
    assert airborne_receptions(claim, 0.0) is claim
    kept = airborne_receptions(claim, 3.0)
    assert kept.rx_sysid.tolist() == [2] and kept.rssi_dbm[0] == claim.rssi_dbm[1]


Cycles = dict[float, list[ObservedClaim]]
Results = tuple[DetectorResult, ...]


def _drive(pipeline: EstimationPipeline, cycles: Cycles) -> tuple[list[str], list[float]]:
    """(uas_ids alerted, every detector statistic) over the traffic's cycles."""
    alerted: list[str] = []
    stats: list[float] = []
    for now in sorted(cycles):
        out = pipeline.step(now, cycles[now])
        alerted += [a.uas_id for a in out.alert_changes]
        stats += [r.statistic for r in out.detector_results]
    return alerted, stats


def test_a_vetoing_review_keeps_the_pipeline_from_alerting() -> None:
    """The review hook decides the alerts: the same traffic alerts on the spoofer without it
    and on nobody with a review that vetoes everything; the statistics are the same."""
    traffic = make_traffic(Scene(seed=3, n_receivers=8, duration_s=30.0))

    def veto(claim: ObservedClaim, results: Results) -> Results:
        return tuple(
            DetectorResult(r.uas_id, r.detector, r.statistic, r.threshold, False) for r in results
        )

    alerted, stats = _drive(EstimationPipeline(PipelineConfig()), traffic.cycles)
    vetoed, vetoed_stats = _drive(EstimationPipeline(PipelineConfig(), veto), traffic.cycles)
    assert SPOOFER_ID in alerted and CYCLE_S > 0.0
    assert vetoed == [] and vetoed_stats == stats


def test_localisation_sigma_is_the_rssi_sigma_inflated() -> None:
    assert PipelineConfig().localisation_sigma_db == 1.0
    cfg = PipelineConfig(rssi_sigma_db=2.0, localisation_noise_inflation=4.0)
    assert cfg.localisation_sigma_db == pytest.approx(4.0)
    with pytest.raises(ValueError, match="localisation_noise_inflation"):
        PipelineConfig(localisation_noise_inflation=0.5)


@pytest.mark.parametrize(
    ("refit_s", "with_spoofer", "fits"), [(0.0, False, 1), (8.0, False, 3), (8.0, True, 3)]
)
def test_the_channel_is_refit_every_refit_s_and_a_track_keeps_the_fit_it_started_on(
    refit_s: float, with_spoofer: bool, fits: int
) -> None:
    """Synthetic traffic (truthful benign claims): one fit, or one every ``refit_s`` on the
    growing labelled set, for the detectors; the spoofer's track keeps the fit in force when
    it started; never a false alert."""
    traffic = make_traffic(Scene(seed=2, n_receivers=8, duration_s=24.0, with_spoofer=with_spoofer))
    cal = CalibrationConfig(enabled=True, min_samples=100, refit_s=refit_s)
    pipeline = CalibratingPipeline(PipelineConfig(calibration=cal))
    seen: list[int] = []
    alerted: set[str] = set()
    held: list[tuple[float, ChannelEstimate | None, ChannelEstimate | None]] = []
    for now in sorted(traffic.cycles):
        out = pipeline.step(now, traffic.cycles[now])
        alerted |= {a.uas_id for a in out.alert_changes}
        if pipeline.estimate is not None and pipeline.estimate.n_samples not in seen:
            seen.append(pipeline.estimate.n_samples)
        if pipeline.inner is not None and pipeline.inner.tracks:
            held.append((now, pipeline.tracks_estimate, pipeline.estimate))
    assert len(seen) == fits and seen == sorted(seen)
    assert alerted == ({SPOOFER_ID} if with_spoofer else set())
    if with_spoofer:
        # From the cycle after the track started: the fit its first claims were mapped with,
        # through later refits.
        started_on = held[0][2]
        assert started_on is not None and held[0][1] is None
        assert all(fit is started_on for _, fit, _ in held[1:])
        assert pipeline.estimate is not started_on  # the detectors took a refit since
