"""One claimed transmitter watched by every registered detector (``registry.DETECTORS``)."""

from __future__ import annotations

from collections.abc import Mapping

from ridsafe.gcs.detection.registry import DETECTORS, Detector, DetectorFactory
from ridsafe.gcs.pipeline_api import DetectorResult, ObservedClaim
from ridsafe.gcs.pipeline_config import PipelineConfig

__all__ = ["TransmitterMonitor"]


class TransmitterMonitor:
    """Every detector's memory for one claimed transmitter (benign or not), made from
    ``detectors`` (the registry unless told otherwise) when the uas_id is first heard."""

    def __init__(
        self,
        uas_id: str,
        cfg: PipelineConfig,
        detectors: Mapping[str, DetectorFactory] = DETECTORS,
    ) -> None:
        self.uas_id = uas_id
        self.detectors: tuple[Detector, ...] = tuple(
            make(uas_id, cfg) for make in detectors.values()
        )

    def observe(self, claim: ObservedClaim) -> tuple[DetectorResult, ...]:
        """Every detector's results on one claim, in registry order."""
        if len(self.detectors) == 1:  # the usual case: no concatenation
            return self.detectors[0].observe(claim)
        results: list[DetectorResult] = []
        for detector in self.detectors:
            results.extend(detector.observe(claim))
        return tuple(results)
