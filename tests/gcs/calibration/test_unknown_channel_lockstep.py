"""The default GCS on a channel nobody told it about: a real lockstep run of the paper's
family (8 aircraft, the aware planner, 60 s) on a radio noisier than configured, with a
path-loss exponent that is not 2 and biased receivers. The default (``calibration.enabled:
auto``) finds the configured channel wrong on its cooperative aircraft and fits it: no
benign aircraft is flagged and the spoofer still is. The same run with the GCS trusting its
configuration (``enabled: false``) flags benign aircraft: what the default protects against.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from ridsafe.common.config import with_overrides
from ridsafe.tools.analysis.metrics import compute_metrics
from ridsafe.tools.run.lockstep import run_lockstep
from ridsafe.tools.run.scenario import REPO_ROOT, load_scenario_file, with_aircraft

CHANNEL = {
    "scenario.radio.shadowing_sigma_db": 2.5,
    "scenario.radio.path_loss_exponent": 2.3,
    "scenario.radio.receiver_bias_sigma_db": 1.5,
    "scenario.seed": 1,
    "scenario.duration_s": 60.0,
}


def _fly(tmp_path: Path, calibration: object) -> dict[str, object]:
    overrides = {**CHANNEL, "pipeline.calibration.enabled": calibration}
    loaded = with_overrides(load_scenario_file(REPO_ROOT / "configs" / "paper.yaml"), overrides)
    loaded = with_aircraft(loaded, 8, overrides)
    out = tmp_path / f"{calibration}" / "run.mcap"
    result = run_lockstep(loaded, "aware", out, recorder_process=False)
    assert result.status == "completed"
    return dict(compute_metrics(out))


@pytest.mark.slow
def test_the_default_gcs_fits_a_channel_it_was_not_told_and_flags_no_benign_aircraft(
    tmp_path: Path,
) -> None:
    default = _fly(tmp_path, "auto")
    assert default["false_alerts"] == 0
    assert default["detection_delay_s"] is not None  # the spoofer is alerted
    assert float(default["containment_rate"]) >= 0.8  # type: ignore[arg-type]
    trusting = _fly(tmp_path, False)
    assert int(trusting["false_alerts"]) >= 4  # type: ignore[call-overload]
