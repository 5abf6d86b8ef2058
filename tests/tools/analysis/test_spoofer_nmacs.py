"""Where a run's benign-spoofer NMACs happen (``analysis.spoofer_nmacs``) and the report's list
of them: hand-built run logs written with the real recorder, every field worked out by hand."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ridsafe.common import topics
from ridsafe.tools.analysis.flight_histories import Stage, stage_of
from ridsafe.tools.analysis.metrics import compute_metrics
from ridsafe.tools.analysis.nmac_report import nmac_section
from ridsafe.tools.analysis.run_arrays import load_run
from ridsafe.tools.analysis.spoofer_nmacs import spoofer_nmacs
from ridsafe.tools.analysis.sweep_results import RunRecord, SweepResults
from ridsafe.tools.sweep.folder import LOG_FILE
from ridsafe.tools.sweep.plan import RunSpec as SweepRunSpec
from tests.tools.analysis.test_metrics import (
    PASSER,
    SPOOFER_SERIAL,
    RunSpec,
    _cli,
    alert,
    opposite,
    region,
    still,
    write_run,
)


def phase(t_s: float, sysid: int, to: str) -> tuple[str, float, dict[str, Any]]:
    record = {"sysid": sysid, "event": "phase", "detail": f"-> {to}", "to": to}
    return (topics.COMPANION_EVENTS, t_s, record)


def decision(t_s: float, sysid: int, status: str) -> tuple[str, float, dict[str, Any]]:
    return (topics.DECISIONS, t_s, {"sysid": sysid, "status": status, "compute_ms": 1.0})


def _pass_run(tmp_path: Path, extra: list[Any], offset_y: float = 40.0) -> Path:
    """PASSER (start (-300, 0, 60), 10 m/s east, goal (500, 0, 0)) meets the spoofer flying
    the other way ``offset_y`` to its north at t = 30 s, at x = 0."""
    spec = RunSpec([PASSER], spoofer=opposite(offset_y), goals=[(500.0, 0.0, 0.0)], extra=extra)
    return write_run(tmp_path / "run.mcap", spec)


def test_a_pass_in_cruise_after_the_alert_inside_the_region(tmp_path: Path) -> None:
    extra = [phase(5.0, 1, "climb"), phase(12.0, 1, "cruise"), phase(50.0, 1, "descend")]
    extra += [decision(29.5, 1, "no_safe_action"), decision(30.5, 1, "cruise")]
    extra += [decision(29.9, 2, "arrived")]  # another aircraft's: not this one's status
    extra.append(alert(20.0))
    # The spoofer is at (0, 40, 60) at t = 30 s; a region centred there, sent at 29.75 s.
    extra.append(region(29.75, (0.0, 40.0, 60.0), 100.0 * np.eye(3)))
    path = _pass_run(tmp_path, extra)
    events = spoofer_nmacs(load_run(path))
    assert len(events) == compute_metrics(path)["nmac_benign_spoofer"] == 1
    event = events[0]
    assert event.t_s == pytest.approx(30.0)
    assert event.distance_m == pytest.approx(40.0)
    assert event.height_m == pytest.approx(60.0)
    assert (event.phase, event.stage) == ("cruise", Stage.CRUISE)
    assert event.from_pad_m == pytest.approx(300.0)
    assert event.from_goal_m == pytest.approx(500.0)
    assert event.alert_lag_s == pytest.approx(10.0)
    assert event.in_region is True
    assert event.planner_status == "no_safe_action"
    assert (event.benign_sysid, event.spoofer_serial) == (1, SPOOFER_SERIAL)


def test_before_the_alert_outside_a_region_or_with_none(tmp_path: Path) -> None:
    """A region 100 m off the truth with 10 m deviations: outside. One older than a second
    before the NMAC: no region. An alert after the NMAC: a negative lag."""
    outside = [alert(33.5), region(29.9, (100.0, 40.0, 60.0), 100.0 * np.eye(3))]
    event = spoofer_nmacs(load_run(_pass_run(tmp_path / "a", outside)))[0]
    assert event.in_region is False
    assert event.alert_lag_s == pytest.approx(-3.5)
    assert (event.phase, event.stage) == (None, Stage.UNKNOWN)
    assert event.planner_status is None  # no decision logged
    stale = [region(28.5, (0.0, 40.0, 60.0), 100.0 * np.eye(3))]
    event = spoofer_nmacs(load_run(_pass_run(tmp_path / "b", stale)))[0]
    assert event.in_region is None
    assert event.alert_lag_s is None


def test_no_event_for_a_pass_beyond_the_radius(tmp_path: Path) -> None:
    assert spoofer_nmacs(load_run(_pass_run(tmp_path, [], offset_y=60.0))) == []


def test_two_passes_are_two_events_at_their_closest_samples(tmp_path: Path) -> None:
    """The spoofer hovers 30 m off the track of an aircraft that flies past, turns at 60 s and
    passes again: closest at 30 s and 90 s."""

    def back_and_forth(t: float) -> tuple[float, float, float]:
        x = -300.0 + 10.0 * t if t <= 60.0 else 300.0 - 10.0 * (t - 60.0)
        return (x, 0.0, 60.0)

    spec = RunSpec([back_and_forth], spoofer=still((0.0, 30.0, 60.0)), duration_s=120.0)
    events = spoofer_nmacs(load_run(write_run(tmp_path / "run.mcap", spec)))
    assert [e.t_s for e in events] == pytest.approx([30.0, 90.0])
    assert [e.distance_m for e in events] == pytest.approx([30.0, 30.0])


@pytest.mark.parametrize(
    ("name", "stage"),
    [("takeoff", Stage.TAKE_OFF), ("cruise", Stage.CRUISE), ("land", Stage.ARRIVAL),
     ("failed", Stage.UNKNOWN), (None, Stage.UNKNOWN)],
)  # fmt: skip
def test_stage_of_a_phase(name: str | None, stage: Stage) -> None:
    assert stage_of(name) is stage


def test_the_report_lists_the_aware_planners_nmacs_from_the_logs(tmp_path: Path) -> None:
    """Only aware runs with an NMAC are read; a run whose log is gone is named, not hidden;
    the summary counts by stage, before the alert, and the spoofer against its region."""
    run_dir = tmp_path / "seed3"
    run_dir.mkdir()
    _pass_run(run_dir, [phase(0.0, 1, "cruise"), alert(20.0)])
    (run_dir / "run.mcap").rename(run_dir / LOG_FILE)

    def record(directory: Path, planner: str, seed: int, nmacs: int) -> RunRecord:
        spec = SweepRunSpec(16, seed, planner, 120.0, (("adversary", "pursue"),), ())
        return RunRecord(directory, spec, {"nmac_benign_spoofer": nmacs})

    records = (
        record(run_dir, "aware", 3, 1),
        record(tmp_path / "gone", "aware", 4, 2),
        record(run_dir, "trust-rid", 3, 1),
        record(tmp_path / "never-read", "aware", 5, 0),
    )
    sweep = SweepResults(tmp_path, "adversaries", "c.yaml", records, (), 0, 0)
    lines = nmac_section([sweep])
    label = "adversaries [adversary=pursue]"
    # 2 of 3 aware runs had one (1 read); cruise 1; after the alert; no region
    assert f"| {label} | 16 | 2 / 3 | 1 | 0 | 1 | 0 | 0 | 0 | 0 / 0 / 1 |" in lines
    event = f"| {label} | 16 | 3 | 30.0 | 40.0 | 60.0 | cruise (cruise) | 300 / 500 | +10.0 | "
    event += "no region | none |"
    assert event in lines
    text = "\n".join(lines)
    assert f"Logs not read: {label} 16 seed 4" in text
    assert "never-read" not in text
    quiet = SweepResults(tmp_path, "a", "c.yaml", (record(run_dir, "trust-rid", 3, 1),), (), 0, 0)
    assert nmac_section([quiet]) == []  # trust-RID's NMACs are not listed


def test_ridsafe_metrics_lists_the_nmacs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _pass_run(tmp_path, [phase(0.0, 1, "cruise"), alert(20.0)])
    code, out, _err = _cli([str(path), "--nmacs"], capsys)
    assert code == 0
    assert "benign-spoofer NMACs: 1" in out
    assert "aircraft 1 - RSAF800000666  40.0 m  height 60.0 m  cruise (cruise)" in out
    assert "+10.0 s from alert  spoofer no region  planner none" in out
    code, out, _err = _cli([str(path), "--json", "--nmacs"], capsys)
    event = json.loads(out)["spoofer_nmac_events"][0]
    assert (event["stage"], event["distance_m"], event["in_region"]) == ("cruise", 40.0, None)
    code, out, _err = _cli([str(path), "--json"], capsys)
    assert "spoofer_nmac_events" not in json.loads(out)
