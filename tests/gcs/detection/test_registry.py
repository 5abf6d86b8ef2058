"""The detector registry: by default the RSSI-consistency bank (the censored test is off),
unchanged by the monitor around it; a newly registered detector runs on every claim and can
raise the alert."""

from __future__ import annotations

import numpy as np
import pytest

from ridsafe.common.messages import AlertState, RidsafeDetector
from ridsafe.gcs.detection.monitor import TransmitterMonitor
from ridsafe.gcs.detection.registry import DETECTORS, DetectorFactory
from ridsafe.gcs.detection.rssi_consistency import RssiConsistencyDetectors
from ridsafe.gcs.pipeline_api import AlertChange, CycleOutput, DetectorResult, ObservedClaim
from ridsafe.gcs.pipeline_config import DetectionConfig, PipelineConfig
from ridsafe.gcs.synthetic.evaluate import run_pipeline
from ridsafe.gcs.synthetic.traffic import SPOOFER_ID, Scene, make_traffic

CEILING_M = 50.0


class ClaimedAltitudeCeiling:
    """A test detector: flags every claim above ``CEILING_M`` (the scene's spoofer claims
    60 m, its benign aircraft fly at 30-100 m). It reports under the MLAT id because a
    test cannot add a wire id; a real detector gets its own (``registry.py``)."""

    def __init__(self, uas_id: str) -> None:
        self.uas_id = uas_id

    @classmethod
    def for_transmitter(cls, uas_id: str, cfg: PipelineConfig) -> ClaimedAltitudeCeiling:
        return cls(uas_id)

    def observe(self, claim: ObservedClaim) -> tuple[DetectorResult, ...]:
        altitude = float(claim.claimed_p_enu_m[2])
        return (
            DetectorResult(
                self.uas_id, RidsafeDetector.MLAT, altitude, CEILING_M, altitude > CEILING_M
            ),
        )


FACTORY: DetectorFactory = ClaimedAltitudeCeiling.for_transmitter  # mypy: the registry's type


def test_the_default_registry_is_the_rssi_bank_and_the_monitor_is_transparent() -> None:
    """The censored test is registered but off by default: the monitor holds the bank only."""
    assert list(DETECTORS) == ["rssi_consistency", "censored_likelihood"]
    cfg = PipelineConfig()
    monitor = TransmitterMonitor(SPOOFER_ID, cfg)
    assert len(monitor.detectors) == 1
    bank = RssiConsistencyDetectors(SPOOFER_ID, cfg.detection, cfg.rssi_sigma_db)
    traffic = make_traffic(Scene(seed=3, n_receivers=8, duration_s=15.0))
    seen = 0
    for claims in traffic.cycles.values():
        for claim in claims:
            if claim.uas_id != SPOOFER_ID:
                continue
            assert monitor.observe(claim) == bank.observe(claim)
            seen += 1
    assert seen > 5


def test_every_registered_detector_reports_in_registry_order() -> None:
    cfg = PipelineConfig()
    both = {"rssi_consistency": DETECTORS["rssi_consistency"], "ceiling": FACTORY}
    monitor = TransmitterMonitor(SPOOFER_ID, cfg, both)
    traffic = make_traffic(Scene(seed=1, n_receivers=6, duration_s=5.0))
    claim = next(c for cs in traffic.cycles.values() for c in cs if c.n_receivers >= 3)
    results = monitor.observe(claim)
    assert [r.detector for r in results] == [
        *RssiConsistencyDetectors.DETECTORS,
        RidsafeDetector.MLAT,
    ]
    assert results[-1].statistic == pytest.approx(float(claim.claimed_p_enu_m[2]))


def test_a_registered_detector_runs_and_raises_the_alert(monkeypatch: pytest.MonkeyPatch) -> None:
    """One registry line (here the only one) and its id in ``detection.alerting``."""
    monkeypatch.delitem(DETECTORS, "rssi_consistency")
    monkeypatch.setitem(DETECTORS, "claimed_altitude_ceiling", FACTORY)
    cfg = PipelineConfig(detection=DetectionConfig(alerting=(RidsafeDetector.MLAT,)))
    traffic = make_traffic(Scene(seed=2, n_receivers=6, duration_s=10.0, receiver_alt_m=(20, 40)))
    results: list[DetectorResult] = []
    changes: list[AlertChange] = []

    def collect(_now: float, out: CycleOutput) -> None:
        results.extend(out.detector_results)
        changes.extend(out.alert_changes)

    metrics = run_pipeline(traffic, cfg, on_cycle=collect)
    delivered = {t: cs for t, cs in traffic.cycles.items() if t <= traffic.scene.duration_s}
    assert len(results) == sum(map(len, delivered.values()))  # one per claim, no RSSI bank
    assert {r.detector for r in results} == {RidsafeDetector.MLAT}
    raised = [c for c in changes if c.state is AlertState.RAISED]
    assert [c.uas_id for c in raised] == [SPOOFER_ID]  # benign aircraft fly below 40 m
    first_spoofer_cycle = min(
        t for t, cs in delivered.items() if any(c.uas_id == SPOOFER_ID for c in cs)
    )
    assert metrics.alert_s == pytest.approx(first_spoofer_cycle)
    assert np.isfinite(metrics.first_region_s)
