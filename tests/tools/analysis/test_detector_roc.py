"""ROC curves of the detectors from logged statistics: labels from ``/run/meta``, the curve and
AUC against textbook computations, hand-written logs through the real recorder."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy import stats

from ridsafe.common import topics
from ridsafe.tools.analysis.detector_roc import ScoreSamples, _roc, detector_rocs, run_scores
from ridsafe.tools.analysis.plots import detector_roc_plot
from ridsafe.tools.runlog.writer import McapRecorder

BENIGN = ("RSAF800000001", "RSAF800000002")
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _stat(t_s: float, uas_id: str, detector: str, statistic: float, decision: bool) -> Any:
    """A record of the layout before 2026-11-30: one per claim and detector."""
    record = {"uas_id": uas_id, "detector": detector, "statistic": statistic}
    return (topics.DETECTOR_STATS, t_s, {**record, "threshold": 6.0, "decision": decision})


def _per_claim(old_layout: list[Any]) -> list[Any]:
    """The same verdicts as the GCS logs them now: one record per claim (a claim's verdicts
    are consecutive records of one uas_id and time)."""
    out: list[Any] = []
    for topic, t_s, record in old_layout:
        verdict = {k: record[k] for k in ("statistic", "threshold", "decision")}
        last = out[-1] if out else None
        if last is not None and (last[1], last[2]["uas_id"]) == (t_s, record["uas_id"]):
            last[2]["detectors"][record["detector"]] = verdict
        else:
            detectors = {record["detector"]: verdict}
            out.append((topic, t_s, {"uas_id": record["uas_id"], "detectors": detectors}))
    return out


def _write(path: Path, records: list[Any], meta_first: bool = True) -> Path:
    aircraft = [{"sysid": k + 1, "serial": serial} for k, serial in enumerate(BENIGN)]
    meta = (topics.RUN_META, 0.0, {"aircraft": aircraft, "spoofer": {"serial": "X"}})
    with McapRecorder(path) as recorder:
        for topic, t_s, record in [meta, *records] if meta_first else [*records, meta]:
            recorder.log(topic, t_s, record)
    return path


def test_claims_are_labelled_by_the_benign_serials_of_the_run(tmp_path: Path) -> None:
    records = [
        _stat(1.0, BENIGN[0], "nis", 1.0, False),
        _stat(1.0, BENIGN[1], "nis", 7.0, True),  # a benign aircraft flagged
        _stat(1.0, "RSAF800000666", "nis", 9.0, True),  # the spoofer
        _stat(1.5, "GHOST0001", "nis", 2.0, False),  # a ghost: a liar too
        _stat(1.5, "GHOST0001", "mlat", float("nan"), False),  # not a number: left out
        _stat(2.0, BENIGN[0], "mlat", 0.5, False),
    ]
    per_claim = _per_claim(records)
    assert len(per_claim) == 5  # the ghost's two verdicts in one record
    for meta_first in (True, False):
        old = run_scores(_write(tmp_path / f"{meta_first}.mcap", records, meta_first))
        new = run_scores(_write(tmp_path / f"{meta_first}-new.mcap", per_claim, meta_first))
        for scores in (old, new):
            nis = scores["nis"]
            assert (nis.liar, nis.benign) == ([9.0, 2.0], [1.0, 7.0])
            assert (nis.liar_flagged, nis.benign_flagged) == (1, 1)
            assert (scores["mlat"].liar, scores["mlat"].benign) == ([], [0.5])
    rocs = detector_rocs([tmp_path / "True.mcap", tmp_path / "False.mcap"])
    assert [r.detector for r in rocs] == ["nis"]  # mlat has no liar's claim: no curve
    assert (rocs[0].liar_records, rocs[0].benign_records) == (4, 4)
    assert (rocs[0].operating_tpr, rocs[0].operating_fpr) == (0.5, 0.5)


def test_the_curve_and_auc_are_the_textbook_ones() -> None:
    rng = np.random.default_rng(7)
    liar = np.round(rng.normal(2.0, 1.0, 300), 1)  # rounded: many ties
    benign = np.round(rng.normal(0.0, 1.0, 500), 1)
    roc = _roc("t", ScoreSamples(list(liar), list(benign), 30, 5))
    assert roc is not None
    u = stats.mannwhitneyu(liar, benign).statistic  # ties count half
    assert roc.auc == pytest.approx(u / (liar.size * benign.size), rel=1e-12)
    # the area under the (step) curve, trapezoids over tied steps, is the same number
    assert np.trapezoid(roc.true_positive_rate, roc.false_positive_rate) == pytest.approx(
        roc.auc, rel=1e-12
    )
    for threshold in (-1.0, 0.5, 2.0, 3.3):
        k = int(np.flatnonzero(np.unique(np.concatenate((liar, benign)))[::-1] >= threshold)[-1])
        assert roc.true_positive_rate[k + 1] == np.mean(liar >= threshold)
        assert roc.false_positive_rate[k + 1] == np.mean(benign >= threshold)
    assert (roc.false_positive_rate[[0, -1]] == (0.0, 1.0)).all()
    assert np.all(np.diff(roc.true_positive_rate) >= 0)
    assert (roc.operating_tpr, roc.operating_fpr) == (0.1, 0.01)


def test_the_plot_is_a_png(tmp_path: Path) -> None:
    roc = _roc("mlat", ScoreSamples([3.0, 4.0, 0.5], [0.0, 1.0, 0.2, 5.0], 2, 0))
    assert roc is not None
    path = detector_roc_plot([roc], tmp_path / "roc.png", "test")
    assert path.read_bytes()[:8] == PNG_MAGIC
