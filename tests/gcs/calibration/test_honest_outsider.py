"""An aircraft that broadcasts the truth but flies no companion of ours (a third party's drone)
must not be flagged. The fleet's own aircraft are protected by the cooperative veto; an
outsider is not, and the sweeps had none: the family's spoofer with its lie set to zero is
one (docs/results/robustness.md, "An honest aircraft outside the fleet is flagged on the
urban preset": 9 of 10 urban runs at 8 aircraft flag it, most when the fit starts and the
held claims are decided against an empirical null of aircraft still on their pads; later
its honest statistics still run above the fleet's, for a reason not found yet)."""

from __future__ import annotations

from pathlib import Path

import pytest

from ridsafe.common.config import with_overrides
from ridsafe.tools.run.lockstep import run_lockstep
from ridsafe.tools.run.scenario import REPO_ROOT, load_scenario_file, with_aircraft
from ridsafe.tools.runlog.reader import read_records


def _alerts_on_an_honest_outsider(tmp_path: Path, config: str, seed: int) -> list[float]:
    """Times of the alerts raised in 12 s of ``config`` at 8 aircraft, aware, whose spoofer
    tells the truth."""
    overrides = {
        "scenario.seed": seed,
        "scenario.duration_s": 12.0,
        "family.spoofer_offset_enu_m": [0.0, 0.0, 0.0],
    }
    loaded = load_scenario_file(REPO_ROOT / "configs" / config)
    loaded = with_aircraft(with_overrides(loaded, overrides), 8, overrides)
    log = tmp_path / "run.mcap"
    assert run_lockstep(loaded, "aware", log, recorder_process=False).status == "completed"
    return [t for _, t, r in read_records(log, {"/gcs/alerts"}) if r["state"] == "raised"]


def test_an_honest_outsider_is_not_alerted_on_a_channel_the_gcs_fits(tmp_path: Path) -> None:
    assert _alerts_on_an_honest_outsider(tmp_path, "robustness.yaml", 1) == []


@pytest.mark.xfail(
    strict=True,
    raises=AssertionError,
    reason="known: an honest aircraft outside the fleet is flagged on the urban preset "
    "(robustness.md, 'An honest aircraft outside the fleet')",
)
def test_an_honest_outsider_is_not_alerted_on_the_urban_preset(tmp_path: Path) -> None:
    assert _alerts_on_an_honest_outsider(tmp_path, "urban.yaml", 1) == []
