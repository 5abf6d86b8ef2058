"""The estimator registry: every entry loads and starts a track; a newly registered estimator
runs in the pipeline by its name; an unknown name or a broken entry fails loudly, naming
``pipeline.estimator``."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pytest

from ridsafe.common.config import from_mapping
from ridsafe.common.errors import ConfigError, FieldValueError
from ridsafe.gcs.localisation import authors_imm, gaussian_sum, nlls_imm
from ridsafe.gcs.localisation.api import StartLocaliser, estimator_start
from ridsafe.gcs.localisation.registry import DEFAULT_ESTIMATOR, ESTIMATORS
from ridsafe.gcs.pipeline_api import ObservedClaim, UnsafeRegion
from ridsafe.gcs.pipeline_config import ForcedAlertConfig, PipelineConfig
from ridsafe.gcs.synthetic.evaluate import run_pipeline
from ridsafe.gcs.synthetic.traffic import SPOOFER_ID, Scene, make_traffic
from ridsafe.gcs.tracking.imm import Gaussian

#: mypy checks that the built-in start functions have the registry's signature.
BUILT_IN: dict[str, StartLocaliser] = {
    "rssi_imm": gaussian_sum.start,
    "nlls_imm": nlls_imm.start,
    "authors_imm": authors_imm.start,
}

CENTROID_VARIANCE_M2 = 1.0e4


class ReceiverCentroid:
    """A deliberately simple estimator for the test: the transmitter sits at the centroid of
    the receivers of its latest claim, 100 m std on every axis, not moving."""

    def __init__(self, claim: ObservedClaim) -> None:
        self.p_enu_m = claim.rx_p_enu_m.mean(axis=0)

    def update(self, claim: ObservedClaim) -> bool:
        self.p_enu_m = claim.rx_p_enu_m.mean(axis=0)
        return True

    def predicted(self, t_s: float) -> tuple[Gaussian, np.ndarray]:
        x = np.zeros((1, 6))
        x[0, :3] = self.p_enu_m
        return Gaussian(x, CENTROID_VARIANCE_M2 * np.eye(6)[None]), np.array([1.0, 0.0])


def start_centroid(
    claims: Sequence[ObservedClaim], cfg: PipelineConfig, after_s: float = -math.inf
) -> tuple[ReceiverCentroid, int] | None:
    for i, claim in enumerate(claims):
        if claim.t_s > after_s and claim.n_receivers >= 3:
            return ReceiverCentroid(claim), i + 1
    return None


@dataclass(frozen=True)
class _Scenario:
    """The shape of a run's YAML around the pipeline section (``pipeline:``)."""

    pipeline: PipelineConfig = field(default_factory=PipelineConfig)


def test_every_registered_estimator_loads_and_is_the_built_in() -> None:
    assert DEFAULT_ESTIMATOR in ESTIMATORS
    assert set(ESTIMATORS) == set(BUILT_IN)
    for name, start in BUILT_IN.items():
        assert estimator_start(name) is start


def test_a_registered_estimator_runs_in_the_pipeline(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(ESTIMATORS, "rx_centroid", f"{__name__}:start_centroid")
    loaded = from_mapping(_Scenario, {"pipeline": {"estimator": "rx_centroid"}}, "run.yaml")
    assert loaded.pipeline.estimator == "rx_centroid"
    cfg = PipelineConfig(
        estimator="rx_centroid", forced_alert=ForcedAlertConfig(True, SPOOFER_ID, 5.0)
    )
    traffic = make_traffic(Scene(seed=0, n_receivers=6, duration_s=20.0))
    regions: list[UnsafeRegion] = []
    run_pipeline(traffic, cfg, on_cycle=lambda _now, out: regions.extend(out.regions))
    assert regions
    centroids = np.array(
        [
            c.rx_p_enu_m.mean(axis=0)
            for claims in traffic.cycles.values()
            for c in claims
            if c.uas_id == SPOOFER_ID
        ]
    )
    for region in regions:
        assert np.min(np.linalg.norm(centroids - region.center_enu_m, axis=1)) < 1e-9
        np.testing.assert_allclose(region.cov_enu_m2, CENTROID_VARIANCE_M2 * np.eye(3))


def test_an_unknown_estimator_names_the_config_key_and_the_choices() -> None:
    with pytest.raises(ConfigError) as info:
        from_mapping(_Scenario, {"pipeline": {"estimator": "kalman"}}, "run.yaml")
    assert info.value.key_path == "pipeline.estimator"
    message = str(info.value)
    assert message.startswith("run.yaml: pipeline.estimator: unknown estimator 'kalman'")
    assert "nlls_imm" in message and "rssi_imm" in message and "registry.py" in message
    with pytest.raises(FieldValueError, match="estimator") as direct:
        PipelineConfig(estimator="kalman")
    assert direct.value.field == "estimator"
    with pytest.raises(FieldValueError, match="unknown estimator 'kalman'"):
        estimator_start("kalman")


@pytest.mark.parametrize(
    ("entry_point", "reason"),
    [
        ("ridsafe.gcs.localisation.no_such_module:start", "does not load"),
        ("ridsafe.gcs.localisation.gaussian_sum:no_such_function", "does not load"),
        ("ridsafe.gcs.localisation.gaussian_sum:PT", "not callable"),
    ],
)
def test_a_broken_entry_says_which_and_why(
    monkeypatch: pytest.MonkeyPatch, entry_point: str, reason: str
) -> None:
    monkeypatch.setitem(ESTIMATORS, "broken", entry_point)
    with pytest.raises(FieldValueError, match=reason) as info:
        estimator_start("broken")
    assert info.value.field == "estimator" and entry_point in str(info.value)
