"""One claimed transmitter watched by every registered detector (``registry.DETECTORS``)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from ridsafe.gcs.detection.registry import DETECTORS, Detector, DetectorFactory
from ridsafe.gcs.pipeline_api import DetectorResult, ObservedClaim
from ridsafe.gcs.pipeline_config import PipelineConfig

__all__ = ["TransmitterMonitor", "observe_batch"]


class TransmitterMonitor:
    """Every detector's memory for one claimed transmitter (benign or not), made from
    ``detectors`` (the registry unless told otherwise) when the uas_id is first heard; the
    ones the configuration turns off (their factory returns None) are left out."""

    def __init__(
        self,
        uas_id: str,
        cfg: PipelineConfig,
        detectors: Mapping[str, DetectorFactory] = DETECTORS,
    ) -> None:
        self.uas_id = uas_id
        made = (make(uas_id, cfg) for make in detectors.values())
        self.detectors: tuple[Detector, ...] = tuple(d for d in made if d is not None)

    def observe(self, claim: ObservedClaim) -> tuple[DetectorResult, ...]:
        """Every detector's results on one claim, in registry order."""
        if len(self.detectors) == 1:  # the usual case: no concatenation
            return self.detectors[0].observe(claim)
        results: list[DetectorResult] = []
        for detector in self.detectors:
            results.extend(detector.observe(claim))
        return tuple(results)


def observe_batch(
    monitors: Sequence[TransmitterMonitor], claims: Sequence[ObservedClaim]
) -> list[tuple[DetectorResult, ...]]:
    """``monitors[j].observe(claims[j])`` for every j (the monitors made from one registry),
    claims in order. A detector class with a static ``observe_batch(detectors, claims)``
    (the same answers as one ``observe`` each, in order) sees all its claims in one call:
    a cycle's transmissions vectorised. The detectors of one registry entry keep their own
    memory, so running entry by entry instead of claim by claim changes nothing."""
    if not monitors:
        return []
    per_entry = []
    for i in range(len(monitors[0].detectors)):
        detectors = [m.detectors[i] for m in monitors]
        kind = type(detectors[0])
        batch = getattr(kind, "observe_batch", None)
        if batch is not None and all(type(d) is kind for d in detectors):
            per_entry.append(batch(detectors, claims))
        else:
            per_entry.append([d.observe(c) for d, c in zip(detectors, claims, strict=True)])
    if len(per_entry) == 1:  # the usual case: no concatenation
        return list(per_entry[0])
    return [tuple(r for entry in per_entry for r in entry[j]) for j in range(len(claims))]
