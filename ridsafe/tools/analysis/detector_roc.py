"""ROC curves of the spoofing detectors, from the statistics every run logs.

Every observed claim gives every detector one verdict (statistic, threshold, decision;
``gcs.detection.registry``), logged together in one ``/gcs/detector_stats`` record per claim
(``detectors``: {name: verdict}; logs written before 2026-11-30 have one record per claim
and detector, its fields at the top level: both are read). A verdict is a *liar's* when its
uas_id is not the serial of one of the run's benign aircraft (``/run/meta`` ``aircraft``:
spoofers and ghosts alike), else a benign one. Pooled over runs, each detector's statistic
then gives:

- the ROC curve: for every threshold, the fraction of the liars' verdicts above it (true
  positive rate) against the fraction of the benign verdicts above it (false positive rate);
- the AUC, P(a liar's verdict outscores a benign one), ties counting half (Mann-Whitney);
- the operating point: the rates of the logged decisions, i.e. at the thresholds the GCS used
  (which may move during a run, e.g. the calibrating GCS's empirical null).

Records of detectors that were not alerting count the same: the ROC shows what each test would
do, not what the configuration made of it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ridsafe.common import topics
from ridsafe.tools.analysis.run_arrays import benign_serials
from ridsafe.tools.runlog.reader import read_records

__all__ = ["DetectorRoc", "ScoreSamples", "detector_rocs", "roc_rows", "run_scores"]

FloatArray = NDArray[np.float64]


@dataclass
class ScoreSamples:
    """One detector's logged statistics, split by who made the claim."""

    liar: list[float] = field(default_factory=list)
    benign: list[float] = field(default_factory=list)
    liar_flagged: int = 0  # logged decisions True on a liar's claim
    benign_flagged: int = 0

    def add(self, other: ScoreSamples) -> None:
        self.liar += other.liar
        self.benign += other.benign
        self.liar_flagged += other.liar_flagged
        self.benign_flagged += other.benign_flagged


def run_scores(log: Path) -> dict[str, ScoreSamples]:
    """Detector name -> its statistics in one run log (non-finite statistics left out)."""
    benign: set[str] = set()
    records: list[tuple[str, str, float, bool]] = []  # (detector, uas_id, statistic, decision)
    for topic, _t_s, record in read_records(log, topics=(topics.RUN_META, topics.DETECTOR_STATS)):
        if topic == topics.RUN_META:
            benign |= set(benign_serials(record))
            continue
        uas_id = str(record.get("uas_id"))
        for detector, verdict in _verdicts(record):
            statistic = verdict.get("statistic")
            if isinstance(statistic, int | float) and math.isfinite(statistic):
                records.append((detector, uas_id, statistic, verdict.get("decision") is True))
    samples: dict[str, ScoreSamples] = {}
    for detector, uas_id, statistic, flagged in records:
        into = samples.setdefault(detector, ScoreSamples())
        if uas_id in benign:
            into.benign.append(float(statistic))
            into.benign_flagged += flagged
        else:
            into.liar.append(float(statistic))
            into.liar_flagged += flagged
    return samples


def _verdicts(record: dict[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    """(detector, {statistic, threshold, decision}) of one ``/gcs/detector_stats`` record,
    either layout (module docstring)."""
    detectors = record.get("detectors")
    if isinstance(detectors, dict):
        return [(str(name), v) for name, v in detectors.items() if isinstance(v, dict)]
    return [(str(record.get("detector")), record)]


@dataclass(frozen=True)
class DetectorRoc:
    detector: str
    liar_records: int
    benign_records: int
    false_positive_rate: FloatArray  # from 0 to 1, thresholds falling
    true_positive_rate: FloatArray
    auc: float
    operating_fpr: float  # the logged decisions' rates
    operating_tpr: float


def _roc(detector: str, samples: ScoreSamples) -> DetectorRoc | None:
    liar = np.asarray(samples.liar, dtype=np.float64)
    benign = np.asarray(samples.benign, dtype=np.float64)
    if liar.size == 0 or benign.size == 0:
        return None
    thresholds = np.unique(np.concatenate((liar, benign)))[::-1]  # falling
    liar_sorted, benign_sorted = np.sort(liar), np.sort(benign)
    # at each threshold: the records with statistic >= it
    tpr = (liar.size - np.searchsorted(liar_sorted, thresholds, side="left")) / liar.size
    fpr = (benign.size - np.searchsorted(benign_sorted, thresholds, side="left")) / benign.size
    fpr = np.concatenate(([0.0], fpr))
    tpr = np.concatenate(([0.0], tpr))
    # Mann-Whitney with ties counted half, from the pooled ranks
    ranks = _average_ranks(np.concatenate((liar, benign)))
    u = float(ranks[: liar.size].sum()) - liar.size * (liar.size + 1) / 2.0
    return DetectorRoc(
        detector,
        int(liar.size),
        int(benign.size),
        fpr,
        tpr,
        u / (liar.size * benign.size),
        samples.benign_flagged / benign.size,
        samples.liar_flagged / liar.size,
    )


def _average_ranks(values: FloatArray) -> FloatArray:
    """1-based ranks, ties given their mean rank."""
    order = np.argsort(values, kind="stable")
    sorted_values = values[order]
    starts = np.concatenate(([True], sorted_values[1:] != sorted_values[:-1]))
    group = np.cumsum(starts) - 1
    first = np.flatnonzero(starts)
    last = np.concatenate((first[1:], [values.size])) - 1
    mean_rank = (first + last) / 2.0 + 1.0
    ranks = np.empty(values.size)
    ranks[order] = mean_rank[group]
    return ranks


def detector_rocs(logs: Iterable[Path]) -> list[DetectorRoc]:
    """Each detector's ROC pooled over ``logs`` (detectors in first-logged order)."""
    pooled: dict[str, ScoreSamples] = {}
    for log in logs:
        for detector, samples in run_scores(log).items():
            pooled.setdefault(detector, ScoreSamples()).add(samples)
    rocs = (_roc(detector, samples) for detector, samples in pooled.items())
    return [roc for roc in rocs if roc is not None]


def roc_rows(label: str, rocs: Sequence[DetectorRoc]) -> list[list[str]]:
    """Report rows: variant, detector, records (liars / benign), AUC, operating point."""
    return [
        [
            label,
            roc.detector,
            f"{roc.liar_records} / {roc.benign_records}",
            f"{roc.auc:.3f}",
            f"{roc.operating_tpr:.3f}",
            f"{roc.operating_fpr:.4f}",
        ]
        for roc in rocs
    ]
