"""PipelineConfig: the paper's parameters as defaults, validation naming the field, loading."""

from __future__ import annotations

import pytest

from ridsafe.common.config import from_mapping, to_mapping, with_overrides
from ridsafe.common.errors import ConfigError, FieldValueError
from ridsafe.common.messages import RidsafeDetector
from ridsafe.gcs.localisation.config import ImmConfig, RssiFilterConfig
from ridsafe.gcs.pipeline_config import ForcedAlertConfig, PipelineConfig


def test_defaults_are_the_papers_where_it_gives_them() -> None:
    cfg = PipelineConfig()
    assert cfg.imm.dt_s == 0.25 and cfg.imm.mu0 == (0.45, 0.55)
    assert cfg.imm.transition == ((0.98, 0.02), (0.16, 0.84))
    assert cfg.imm.q_cv_diag == (2.0, 2.0, 2.0, 120.0, 120.0, 120.0)
    assert cfg.imm.q_ca_diag == (4.0, 4.0, 4.0, 50.0, 50.0, 50.0, 20.0, 20.0, 20.0)
    assert cfg.imm.r_cv_diag == (400.0,) * 3 and cfg.imm.r_ca_diag == (50.0,) * 3
    assert cfg.detection.nis_threshold == 6.63 and cfg.region.alpha == 0.05
    assert cfg.multilateration.method == "trf" and cfg.multilateration.min_receivers == 4
    assert cfg.forced_alert.time_s == 5.0 and not cfg.forced_alert.enabled
    assert cfg.rssi_sigma_db == 1.0  # the scenario's default shadowing
    assert cfg.estimator == "rssi_imm"
    assert RidsafeDetector.MLAT in cfg.detection.alerting


@pytest.mark.parametrize(
    ("make", "field"),
    [
        (lambda: ImmConfig(transition=((0.98, 0.02), (0.16, 0.81))), "transition[1]"),
        (lambda: ImmConfig(transition=((1.2, -0.2), (0.16, 0.84))), "transition[0][0]"),
        (lambda: ImmConfig(mu0=(0.5, 0.6)), "mu0"),
        (lambda: ImmConfig(q_cv_diag=(2, 2, 2, -1, 120, 120)), "q_cv_diag[3]"),
        (lambda: ImmConfig(r_ca_diag=(50, 0, 50)), "r_ca_diag[1]"),
        (lambda: ImmConfig(q_ca_diag=(1.0,) * 6), "q_ca_diag"),
        (lambda: ForcedAlertConfig(enabled=True), "uas_id"),
        (lambda: RssiFilterConfig(altitude_hypotheses_m=()), "altitude_hypotheses_m"),
        (lambda: RssiFilterConfig(max_hypotheses=2), "max_hypotheses"),
        (lambda: RssiFilterConfig(weight_memory_s=-1.0), "weight_memory_s"),
        (lambda: PipelineConfig(rssi_sigma_db=0.0), "rssi_sigma_db"),
    ],
)
def test_validation_names_the_field(make: object, field: str) -> None:
    with pytest.raises(FieldValueError) as info:
        make()  # type: ignore[operator]
    assert info.value.field == field


def test_loading_reports_file_and_key_path() -> None:
    data = {"imm": {"transition": [[0.98, 0.02], [0.16, 0.81]]}}
    with pytest.raises(ConfigError, match=r"gcs\.yaml: imm\.transition\[1\]: sums to 0\.97"):
        from_mapping(PipelineConfig, data, "gcs.yaml")
    with pytest.raises(ConfigError, match="estimator"):
        from_mapping(PipelineConfig, {"estimator": "kalman"}, "gcs.yaml")


def test_round_trip_and_overrides() -> None:
    cfg = with_overrides(PipelineConfig(), {"estimator": "nlls_imm", "detection.alerting": ["NIS"]})
    assert cfg.estimator == "nlls_imm" and cfg.detection.alerting == (RidsafeDetector.NIS,)
    assert from_mapping(PipelineConfig, to_mapping(cfg), "x") == cfg
