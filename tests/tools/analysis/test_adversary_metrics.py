"""Per-adversary metrics on a real lockstep run of the issue's example (four spoofers of every
motion and claim kind, one ghost): every spoofer's NMACs counted, a ghost's alert not false,
the mean over spoofers, the benign path length and arrival for the cost of ghosts.

Oracle for the NMAC sum: the per-adversary rows, each counted by the same entry-event rule as
``nmac_benign_spoofer`` of a one-spoofer run; for the single-spoofer case, the plain metrics.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from ridsafe.common import topics
from ridsafe.common.config import load_config
from ridsafe.tools.analysis.adversary_metrics import harm_lie_m, pad_holds, per_adversary
from ridsafe.tools.analysis.metrics import compute_metrics
from ridsafe.tools.analysis.run_arrays import load_run
from ridsafe.tools.run.lockstep import run_lockstep
from ridsafe.tools.run.scenario import ScenarioFile
from ridsafe.tools.runlog.writer import McapRecorder

EXAMPLE = Path(__file__).parents[2] / "common" / "adversaries_example.yaml"


@pytest.fixture(scope="module")
def example_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    loaded = load_config(EXAMPLE, ScenarioFile)
    loaded = dataclasses.replace(
        loaded, scenario=dataclasses.replace(loaded.scenario, duration_s=20.0)
    )
    out = tmp_path_factory.mktemp("adversaries") / "run.mcap"
    run_lockstep(loaded, "aware", out)
    return out


def test_every_adversary_has_a_row_and_the_totals_add_up(example_run: Path) -> None:
    run = load_run(example_run)
    rows = per_adversary(run, 1.0)
    assert [r["role"] for r in rows] == ["spoofer"] * 4 + ["ghost"]
    metrics = compute_metrics(run)
    assert metrics["spoofer_count"] == 4
    assert metrics["nmac_benign_spoofer"] == sum(r["nmac_benign"] for r in rows[:4])
    raised = {str(a.get("uas_id")) for _t, a in run.alerts if a.get("state") == "raised"}
    benign = {a.serial for a in load_config(EXAMPLE, ScenarioFile).scenario.aircraft}
    assert metrics["false_alerts"] == len(raised & benign)  # adversaries' alerts are not false
    assert metrics["spoofers_alerted"] == sum(r["alert_time_s"] is not None for r in rows[:4])
    assert metrics["ghosts_alerted"] == int(rows[4]["alert_time_s"] is not None)
    on_ground = sum(r["regions_on_ground"] for r in rows[:4])
    assert metrics["spoofer_regions_on_ground"] == on_ground == 0  # the example's GCS: no ghosts
    known = [r["containment_rate"] for r in rows[:4] if r["containment_rate"] is not None]
    if known:
        assert metrics["containment_rate"] == pytest.approx(float(np.mean(known)))
    assert metrics["benign_path_length_m"] is not None and metrics["benign_path_length_m"] > 100.0


def test_the_drifting_spoofers_lie_is_measured_against_the_harm_distance(example_run: Path) -> None:
    """Spoofer 2 drifts at 2 m/s from 5 s: its lie passes harm_lie_m (100 - 50 m) at 30 s, so
    within the 20 s run it never can hurt; the offset spoofer lies 70.7 m from the start."""
    run = load_run(example_run)
    assert harm_lie_m(run) == 50.0
    rows = {r["serial"]: r for r in per_adversary(run, 1.0)}
    assert rows["RSAF800000667"]["harm_time_s"] is None
    assert rows["RSAF800000667"]["alerted_before_harm"]
    offset = rows["RSAF800000666"]
    assert offset["harm_time_s"] == pytest.approx(0.0, abs=0.11)
    if offset["alert_time_s"] is not None:
        assert offset["lie_at_alert_m"] == pytest.approx(70.71, abs=0.01)


def test_pad_holds_are_summed_per_holder_from_the_companions_events(tmp_path: Path) -> None:
    """Oracle: hand-summed intervals of a written log; a hold still on at the end counts to
    the end, a hold that changes holder closes the first."""
    events = [
        (10.0, 1, "pad_blocked", "wait_departure: region RSAF800000777"),  # ghost 10-14
        (14.0, 1, "pad_blocked", "wait_departure: region RSAF800000666"),  # spoofer 14-20
        (20.0, 1, "pad_clear", "wait_departure: pad clear"),
        (12.0, 2, "pad_blocked", "descend: aircraft RSAF800000003"),  # aircraft 12-15
        (15.0, 2, "pad_clear", "descend: pad clear"),
        (30.0, 3, "pad_blocked", "wait_departure: region RSAF800000778"),  # ghost 30-40 (end)
        (31.0, 4, "autopilot_seen", "mode STABILIZE"),
    ]
    path = tmp_path / "run.mcap"
    with McapRecorder(path) as recorder:
        for t_s, sysid, event, detail in sorted(events):
            recorder.log(
                topics.COMPANION_EVENTS, t_s, {"sysid": sysid, "event": event, "detail": detail}
            )
    roles = {"RSAF800000666": "spoofer", "RSAF800000777": "ghost", "RSAF800000778": "ghost"}
    assert pad_holds(path, 40.0, roles) == {
        "pad_hold_s_ghosts": 14.0,
        "pad_hold_s_other_regions": 6.0,
        "pad_hold_s_aircraft": 3.0,
        "aircraft_held_by_ghosts": 2,
    }
