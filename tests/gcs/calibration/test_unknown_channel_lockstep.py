"""The default GCS on a channel nobody told it about: a real lockstep run of the paper's
family (8 aircraft, the aware planner, 60 s) on a radio noisier than configured, with a
path-loss exponent that is not 2 and biased receivers. The default (``calibration.enabled:
auto``) finds the configured channel wrong on its cooperative aircraft and fits it: no
benign aircraft is flagged and the spoofer still is. The same run with the GCS trusting its
configuration (``enabled: false``) flags benign aircraft: what the default protects against.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from ridsafe.common import topics
from ridsafe.common.config import with_overrides
from ridsafe.tools.analysis.metrics import compute_metrics
from ridsafe.tools.run.lockstep import run_lockstep
from ridsafe.tools.run.scenario import REPO_ROOT, load_scenario_file, with_aircraft
from ridsafe.tools.runlog.reader import read_records

CHANNEL = {
    "scenario.radio.shadowing_sigma_db": 2.5,
    "scenario.radio.path_loss_exponent": 2.3,
    "scenario.radio.receiver_bias_sigma_db": 1.5,
    "scenario.seed": 1,
    "scenario.duration_s": 60.0,
}


def _fly(tmp_path: Path, calibration: object) -> tuple[dict[str, object], list[dict[str, Any]]]:
    overrides = {**CHANNEL, "pipeline.calibration.enabled": calibration}
    loaded = with_overrides(load_scenario_file(REPO_ROOT / "configs" / "paper.yaml"), overrides)
    loaded = with_aircraft(loaded, 8, overrides)
    out = tmp_path / f"{calibration}" / "run.mcap"
    result = run_lockstep(loaded, "aware", out, recorder_process=False)
    assert result.status == "completed"
    channel = [r for _, _, r in read_records(out, topics=(topics.GCS_CHANNEL,))]
    return dict(compute_metrics(out)), channel


@pytest.mark.slow
def test_the_default_gcs_fits_a_channel_it_was_not_told_and_flags_no_benign_aircraft(
    tmp_path: Path,
) -> None:
    default, channel = _fly(tmp_path, "auto")
    # The log says which channel the GCS took, and why: the configured one failed its test.
    assert channel[0]["channel"] == "fitted" and channel[0]["p_value"] < 1e-3
    assert 2.0 < channel[0]["exponent"] < 2.6 and channel[0]["residual_std_db"] > 2.0
    assert default["false_alerts"] == 0
    assert default["detection_delay_s"] is not None  # the spoofer is alerted
    assert float(default["containment_rate"]) >= 0.8  # type: ignore[arg-type]
    trusting, channel = _fly(tmp_path, False)
    assert channel == []  # no calibration, no channel records
    assert int(trusting["false_alerts"]) >= 4  # type: ignore[call-overload]
