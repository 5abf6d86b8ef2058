"""What became of each aircraft's delivery (``analysis.deliveries``) and ``ridsafe metrics
--deliveries``: a hand-built run log written with the real recorder, one aircraft per outcome,
every field worked out by hand."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from ridsafe.tools.analysis.deliveries import Outcome, deliveries, outcome_counts
from ridsafe.tools.analysis.flight_histories import Stage
from ridsafe.tools.analysis.metrics import compute_metrics
from ridsafe.tools.analysis.run_arrays import load_run
from tests.tools.analysis.test_metrics import RunSpec, _cli, line, still, write_run
from tests.tools.analysis.test_spoofer_nmacs import phase


def _held(t: float) -> tuple[float, float, float]:
    """Flies east at 10 m/s and stops 40 m short of its goal (300, 200) at t = 26 s."""
    return (min(10.0 * t, 260.0), 200.0, 60.0)


def _lands(t: float) -> tuple[float, float, float]:
    """Slides south at 1 m/s from (300, 260) at 20 m (within 10 m of its goal (300, 210) from
    40 s on), stops over it at 50 s and touches down there at 95 s."""
    return (300.0, max(260.0 - t, 210.0), 0.0 if t >= 95.0 else 20.0)


def _down_beside(t: float) -> tuple[float, float, float]:
    """Over its goal (500, -500) at 20 m from the start, pushed east at 1 m/s, down 60 m
    beside it at 60 s."""
    return (500.0 + min(t, 60.0), -500.0, 0.0 if t >= 60.0 else 20.0)


def _descends(t: float) -> tuple[float, float, float]:
    """Over its goal (-300, -300) from the start, sinking at 0.8 m/s from 90 m: 10 m up at
    the end (100 s)."""
    return (-300.0, -300.0, 90.0 - 0.8 * t)


def _run(tmp_path: Path) -> Path:
    aircraft = [
        line((0.0, 0.0, 60.0), (10.0, 0.0, 0.0)),  # 1: delivers at 29 s (10 m short of 300)
        line((0.0, 100.0, 30.0), (5.0, 0.0, 0.0)),  # 2: low and slow, 100 m short at the end
        _held,  # 3: held 40 m from its goal from 26 s on
        _lands,  # 4: descends on a site 10 m from 3's, on the ground at 95 s
        still((0.0, -300.0, 60.0)),  # 5: hovers where it took off
        still((0.0, 400.0, 0.0)),  # 6: never leaves the ground
        _descends,  # 7: arrived at once, still on its way down at the end
        _down_beside,  # 8: arrived at once, landed 60 m beside its site
    ]
    goals = [
        (300.0, 0.0, 0.0),
        (600.0, 100.0, 0.0),
        (300.0, 200.0, 0.0),
        (300.0, 210.0, 0.0),
        (400.0, -300.0, 0.0),
        (0.0, 700.0, 0.0),
        (-300.0, -300.0, 0.0),
        (500.0, -500.0, 0.0),
    ]
    extra = [phase(1.0, 4, "cruise"), phase(5.0, 4, "descend"), phase(90.0, 4, "land")]
    spec = RunSpec(aircraft, goals=goals, duration_s=100.0, extra=extra)
    return write_run(tmp_path / "run.mcap", spec)


def test_one_aircraft_of_each_outcome_worked_out_by_hand(tmp_path: Path) -> None:
    path = _run(tmp_path)
    rows = {row.sysid: row for row in deliveries(load_run(path))}
    assert [rows[s].outcome for s in sorted(rows)] == [
        Outcome.DELIVERED,
        Outcome.LATE,
        Outcome.HELD_NEAR_GOAL,
        Outcome.DELIVERED,
        Outcome.STALLED,
        Outcome.NOT_LAUNCHED,
        Outcome.DELIVERED,
        Outcome.DELIVERED,
    ]
    delivered = rows[1]
    assert delivered.arrived_s == pytest.approx(29.0)
    assert delivered.trip_m == pytest.approx(300.0)
    assert delivered.flight_s == pytest.approx(29.0)
    assert delivered.progress_m_s == pytest.approx(300.0 / 29.0)
    assert delivered.low_fraction == 0.0
    assert delivered.landed_s is None  # still in the air at the end
    assert delivered.descending_at_end is False  # flew on past its goal at 60 m
    late = rows[2]
    assert late.end_from_goal_m == pytest.approx(100.0)
    assert late.progress_m_s == pytest.approx(500.0 / 100.0)  # 600 m trip, 100 m left
    assert late.low_fraction == 1.0  # 30 m, its cruise altitude 60 m
    assert late.near_goal_s is None
    held = rows[3]
    assert held.near_goal_s == pytest.approx(25.0)  # 50 m short at 25 s
    assert (held.end_from_goal_m, held.closest_m) == pytest.approx((40.0, 40.0))
    assert (held.holder_sysid, held.holder_stage) == (4, Stage.ARRIVAL)
    assert rows[4].arrived_s == pytest.approx(40.0)
    assert rows[4].landed_s == pytest.approx(95.0)
    assert rows[4].descending_at_end is None  # landed
    assert rows[7].descending_at_end is True
    assert rows[7].landed_s is None
    assert rows[8].arrived_s == 0.0 and rows[8].landed_s is None  # not on its site
    assert rows[8].down_beside_site and rows[8].descending_at_end is None
    assert not any(rows[s].down_beside_site for s in range(1, 8))
    assert late.descending_at_end is None  # did not arrive
    assert rows[5].progress_m_s == pytest.approx(0.0)
    assert rows[6].took_off_s is None
    assert rows[6].trip_m == pytest.approx(300.0)
    counts = outcome_counts(list(rows.values()))
    assert counts[Outcome.DELIVERED] == 4
    assert sum(counts.values()) == 8
    metrics = compute_metrics(path)
    assert metrics["goal_reached_fraction"] == pytest.approx(4 / 8)
    assert metrics["landed_fraction"] == pytest.approx(1 / 8)  # aircraft 4 only


def test_ridsafe_metrics_lists_what_became_of_the_undelivered(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = str(_run(tmp_path))
    code, out, _err = _cli([path, "--deliveries"], capsys)
    assert code == 0
    assert (
        "deliveries of 8 aircraft: 4 delivered, 1 not launched, 1 held near the goal, 1 late, "
        "1 stalled en route" in out
    )
    assert (
        "landed within the run: 1 of the 4 that arrived, median 55.0 s after arriving; "
        "1 down beside their sites (aircraft 8)" in out
    )
    in_the_air = "in the air at the end: 1 descending over their sites, 1 not descending"
    assert f"{in_the_air} (aircraft 1)" in out
    lines = [ln.strip() for ln in out.splitlines() if ln.strip().startswith("aircraft ")]
    assert [ln.split(":")[0] for ln in lines] == [f"aircraft {s}" for s in (2, 3, 5, 6)]
    assert "nearest at its goal: aircraft 4 (arrival and landing)" in lines[1]
    code, out, _err = _cli([path, "--deliveries", "--json"], capsys)
    rows = json.loads(out)["deliveries"]
    assert [r["outcome"] for r in rows][:3] == ["delivered", "late", "held near the goal"]
    assert rows[2]["holder_stage"] == "arrival and landing"
    assert [r["descending_at_end"] for r in rows] == [False, *[None] * 5, True, None]
    assert [r["down_beside_site"] for r in rows] == [False] * 7 + [True]
