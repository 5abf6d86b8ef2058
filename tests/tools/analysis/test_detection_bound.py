"""The oracle bound on detection delay: a hand-built log (static receivers, a static spoofer
lying by a fixed offset), the evidence worked out by hand, through the real recorder."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from ridsafe.common import topics
from ridsafe.tools.analysis.detection_bound import (
    detection_bound_s,
    main,
    required_lambda,
    separation_curve,
)
from ridsafe.tools.runlog.writer import McapRecorder

RECEIVERS = np.array([[0.0, 0.0, 50.0], [400.0, 0.0, 50.0], [0.0, 400.0, 50.0], [400, 400, 50]])
SPOOFER = np.array([150.0, 100.0, 60.0])
OFFSET = np.array([60.0, 80.0, 0.0])


def _log(path: Path, transmissions: int) -> Path:
    positions = np.vstack((RECEIVERS, SPOOFER)).tolist()
    meta = {"spoofer": {"sysid": 5, "serial": "X", "offset_enu_m": OFFSET.tolist()}}
    with McapRecorder(path) as recorder:
        recorder.log(topics.RUN_META, 0.0, meta)
        for k in range(transmissions):
            t_s = 1.0 + k
            recorder.log(topics.TRUTH, t_s, {"sysid": [1, 2, 3, 4, 5], "p_enu_m": positions})
            heard = [
                {"sender": 5, "receiver": r, "msg_type": 1, "rssi_dbm": -70.0} for r in (1, 2, 3, 4)
            ]
            benign = [{"sender": 1, "receiver": 2, "msg_type": 1, "rssi_dbm": -60.0}]  # ignored
            recorder.log(topics.RADIO_RX, t_s, {"items": heard + benign})
    return path


def test_the_evidence_grows_by_the_hand_worked_amount_per_transmission(tmp_path: Path) -> None:
    curve = separation_curve(_log(tmp_path / "run.mcap", 10))
    true_d = np.linalg.norm(SPOOFER - RECEIVERS, axis=1)
    claim_d = np.linalg.norm(SPOOFER + OFFSET - RECEIVERS, axis=1)
    d = 10.0 * np.log10(claim_d / true_d)
    per_transmission = float(np.sum((d - d.mean()) ** 2))  # the unknown power removed
    np.testing.assert_allclose(curve.unit_lambda, per_transmission * np.arange(1, 11), rtol=1e-9)
    assert curve.heard_by_s == 1.0  # all four hear the first transmission
    needed = required_lambda(1e-6, 0.5)
    assert needed == pytest.approx(4.753424**2, rel=1e-6)
    for exponent, sigma in ((2.0, 1.0), (2.0, 3.0), (3.0, 2.0)):
        k = math.ceil(needed / ((exponent / sigma) ** 2 * per_transmission))  # transmissions
        expected = k - 1.0 if k <= 10 else math.inf  # one per second from t = 1 s
        assert detection_bound_s(curve, exponent, sigma, needed) == expected


def test_the_command_prints_every_channel(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = _log(tmp_path / "run.mcap", 5)
    assert main([str(log), "--exponents", "2", "--sigmas", "1,6"]) == 0
    printed = capsys.readouterr().out
    assert "exponent 2, sigma 1 dB:" in printed and "exponent 2, sigma 6 dB:" in printed
    assert "1 runs" in printed and "sigma 6 dB: never / never / never" in printed


def test_a_log_without_a_constant_offset_spoofer_is_a_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / "no_spoofer.mcap"
    with McapRecorder(log) as recorder:
        recorder.log(topics.RUN_META, 0.0, {"aircraft": []})
    assert main([str(log)]) == 2
    assert "no spoofer with a constant offset" in capsys.readouterr().err
    assert main([str(tmp_path / "missing.mcap")]) == 2
