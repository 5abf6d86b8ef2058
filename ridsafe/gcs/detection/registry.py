"""The spoofing detectors that watch every claimed transmitter.

Every entry of ``DETECTORS`` makes one transmitter's detector memory; the pipeline makes one
of each for every uas_id it hears (``monitor.TransmitterMonitor``) and shows it every observed
claim of that uas_id. Every result is logged (``/gcs/detector_stats``); a detector whose id
is listed in ``pipeline.detection.alerting`` raises the alert on its first positive decision.

How to add a detector (one new module plus one line here):

1. Write ``ridsafe/gcs/detection/<name>.py`` with a class whose instance holds one claimed
   transmitter's memory and has the ``Detector`` method
   ``observe(claim) -> tuple[DetectorResult, ...]`` (one result per test it runs: statistic,
   threshold, decision), and a constructor ``(uas_id, cfg: PipelineConfig) -> instance``
   (a classmethod such as ``RssiConsistencyDetectors.for_transmitter``; it may return None
   where the configuration turns the detector off). A compiled kernel,
   if it needs one, goes beside it as ``<name>_kernels.py`` (``ridsafe.common.jit``).
2. Add ``"<name>": <Class>.for_transmitter`` to ``DETECTORS`` below.

A result names its test by a ``RidsafeDetector`` id: alerts carry it to the companions
(``RIDSAFE_ALERT.detector``), so a new test also needs its id in the dialect's
``RIDSAFE_DETECTOR`` enum and in ``ridsafe.common.messages.RidsafeDetector``. Parameters go
in ``DetectionConfig`` (``ridsafe/gcs/pipeline_config.py``). ``bench/bench_gcs.py --mc``
reports every detector's ROC AUC and the benign aircraft it would flag.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from ridsafe.gcs.detection.censored import CensoredLikelihoodDetector
from ridsafe.gcs.detection.rssi_consistency import RssiConsistencyDetectors
from ridsafe.gcs.pipeline_api import DetectorResult, ObservedClaim
from ridsafe.gcs.pipeline_config import PipelineConfig

__all__ = ["DETECTORS", "Detector", "DetectorFactory"]


class Detector(Protocol):
    """One claimed transmitter's memory of one detector (or of a bank run together)."""

    def observe(self, claim: ObservedClaim) -> tuple[DetectorResult, ...]:
        """Test one observed claim of this transmitter: one result per test (may be none,
        e.g. too few receivers)."""
        ...


#: (uas_id, the pipeline's configuration) -> that transmitter's detector (None: not run
#: with this configuration)
DetectorFactory = Callable[[str, PipelineConfig], Detector | None]

#: name -> factory; every registered detector runs on every claim, in this order.
DETECTORS: dict[str, DetectorFactory] = {
    # NIS (the paper's), POWER_SPREAD, NIS_WINDOW, CUSUM, MLAT: the RSSI against the claim
    "rssi_consistency": RssiConsistencyDetectors.for_transmitter,
    # MLAT_CENSORED: with detection.censored_window_s > 0, where the calibration estimates
    # the receivers' cut
    "censored_likelihood": CensoredLikelihoodDetector.for_transmitter,
}
