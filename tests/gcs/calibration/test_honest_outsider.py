"""An aircraft that broadcasts the truth but flies no companion of ours (a third party's drone,
the family's ``bystander``) must not be flagged. The fleet's own aircraft are protected by the
cooperative veto; a bystander is not (docs/results/robustness.md, "Bystanders: honest
aircraft outside the fleet": on the urban preset most runs flag it, most when the fit starts
and the held claims are decided against an empirical null of aircraft still on their pads).

The metrics count every alert on a bystander as a false alert; the oracle here is the alert
records themselves."""

from __future__ import annotations

from pathlib import Path

import pytest

from ridsafe.common.config import with_overrides
from ridsafe.tools.analysis.metrics import compute_metrics
from ridsafe.tools.analysis.run_arrays import load_run
from ridsafe.tools.run.lockstep import run_lockstep
from ridsafe.tools.run.scenario import REPO_ROOT, load_scenario_file, with_aircraft
from ridsafe.tools.runlog.reader import read_records

BYSTANDER = "RSAF800000888"


def _fly_with_a_bystander(
    tmp_path: Path,
    config: str,
    seed: int,
    duration_s: float,
    n_aircraft: int = 8,
    settings: dict[str, object] | None = None,
) -> Path:
    """``config`` at ``n_aircraft`` aircraft, aware, with the family's spoofer and one
    bystander (and the overrides ``settings``)."""
    overrides: dict[str, object] = {
        "scenario.seed": seed,
        "scenario.duration_s": duration_s,
        "family.adversaries.preset": "bystander",
        **(settings or {}),
    }
    loaded = load_scenario_file(REPO_ROOT / "configs" / config)
    loaded = with_aircraft(with_overrides(loaded, overrides), n_aircraft, overrides)
    log = tmp_path / "run.mcap"
    assert run_lockstep(loaded, "aware", log, recorder_process=False).status == "completed"
    return log


def _raised(log: Path) -> list[tuple[float, str]]:
    return [
        (t, str(r["uas_id"]))
        for _, t, r in read_records(log, {"/gcs/alerts"})
        if r["state"] == "raised"
    ]


def test_a_bystander_is_not_alerted_on_a_channel_the_gcs_fits(tmp_path: Path) -> None:
    log = _fly_with_a_bystander(tmp_path, "robustness.yaml", 1, 40.0)
    raised = _raised(log)
    assert [serial for _, serial in raised if serial != "RSAF800000666"] == []
    assert any(serial == "RSAF800000666" for _, serial in raised)  # the spoofer still is
    metrics = compute_metrics(load_run(log))
    assert (metrics["false_alerts"], metrics["bystanders_alerted"]) == (0, 0)


@pytest.mark.parametrize("lift", [True, False])
def test_a_bystander_heard_near_the_sensitivity_is_not_alerted(tmp_path: Path, lift: bool) -> None:
    """Exponent 3, 16 aircraft, seed 9: the bystander crosses where the -95 dBm receivers
    hear it near their sensitivity, and what they report runs above the links' mean. With
    the lift left in the fit and the detectors it was alerted at 30 s (MLAT_LONG 6.4;
    robustness.md, "The receivers' sensitivity"); corrected, not."""
    settings: dict[str, object] = {
        "scenario.radio.path_loss_exponent": 3.0,
        "pipeline.calibration.sensitivity_lift": lift,
        # The flight it was found in: with the strangers' regions the aircraft keep clear of
        # the bystander and hear it from elsewhere, and nothing is left to correct.
        "pipeline.tracks.strangers_after_claims": 0,
    }
    log = _fly_with_a_bystander(tmp_path, "robustness.yaml", 9, 32.0, 16, settings)
    on_bystander = [t for t, serial in _raised(log) if serial == BYSTANDER]
    assert (on_bystander == []) == lift


def test_alerts_on_a_bystander_count_as_false_alerts(tmp_path: Path) -> None:
    """Urban, seed 1: the bystander is alerted (the known failure below), so the count has
    something to count; the oracle is the alert records."""
    log = _fly_with_a_bystander(tmp_path, "urban.yaml", 1, 30.0)
    run = load_run(log)
    raised = _raised(log)
    fleet = {a["serial"] for a in run.meta["aircraft"]}
    on_bystander = sum(1 for _, serial in raised if serial == BYSTANDER)
    on_fleet = sum(1 for _, serial in raised if serial in fleet)
    assert on_bystander >= 1
    metrics = compute_metrics(run)
    assert metrics["false_alerts"] == on_fleet + on_bystander
    assert (metrics["bystander_count"], metrics["bystanders_alerted"]) == (1, 1)
    assert metrics["spoofer_count"] == 1  # the bystander is no spoofer
    assert metrics["alert_time_s"] == min(t for t, s in raised if s == "RSAF800000666")


@pytest.mark.xfail(
    strict=True,
    raises=AssertionError,
    reason="known: an honest aircraft outside the fleet is flagged on the urban preset "
    "(robustness.md, 'Bystanders: honest aircraft outside the fleet')",
)
def test_a_bystander_is_not_alerted_on_the_urban_preset(tmp_path: Path) -> None:
    raised = _raised(_fly_with_a_bystander(tmp_path, "urban.yaml", 1, 12.0))
    assert [serial for _, serial in raised if serial == BYSTANDER] == []
