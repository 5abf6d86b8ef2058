"""Tests of ridsafe.tools.analysis.metrics and ``ridsafe metrics``: hand-built run logs written
with the real recorder, metrics checked against numbers worked out by hand."""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import shutil
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from numpy.typing import NDArray

from ridsafe.common import topics
from ridsafe.tools.analysis.metrics import METRIC_KEYS, compute_metrics
from ridsafe.tools.analysis.run_arrays import load_run
from ridsafe.tools.analysis.series import metric_series
from ridsafe.tools.cli import metrics_cmd
from ridsafe.tools.runlog.writer import McapRecorder

FloatArray = NDArray[np.float64]
Position = Callable[[float], tuple[float, float, float]]

SPOOFER_SERIAL = "RSAF800000666"
CHI2_95 = 7.814727903251178  # chi2_3 quantile at 0.95
ORIGIN = {"lat_deg": 36.1447, "lon_deg": -86.8027, "alt_m": 180.0}


def line(start: Sequence[float], velocity: Sequence[float]) -> Position:
    """Straight-line motion p(t) = start + velocity t."""
    return lambda t: (
        start[0] + velocity[0] * t,
        start[1] + velocity[1] * t,
        start[2] + velocity[2] * t,
    )


def still(p: Sequence[float]) -> Position:
    return line(p, (0.0, 0.0, 0.0))


@dataclass
class RunSpec:
    """A hand-built run: benign trajectories (sysid 1..n), optional spoofer (sysid n + 1)."""

    benign: list[Position]
    spoofer: Position | None = None
    duration_s: float = 60.0
    armed: Callable[[int, float], bool] = lambda sysid, t: True
    goals: list[tuple[float, float, float]] | None = None
    scenario: dict[str, Any] = field(default_factory=dict)
    extra: list[tuple[str, float, dict[str, Any]]] = field(default_factory=list)
    end: dict[str, Any] | None = None

    def truth_times(self) -> FloatArray:
        return np.round(np.arange(0.0, self.duration_s + 1e-9, 0.1), 10)


def write_run(path: Path, spec: RunSpec) -> Path:
    n = len(spec.benign)
    spoofer_sysid = n + 1 if spec.spoofer is not None else None
    goals = spec.goals or [(5000.0, 5000.0, 0.0)] * n
    meta = {
        "mode": "lockstep",
        "seed": 0,
        "planner": "spoofing_aware",
        "scenario": {"scenario": {"origin": ORIGIN}, **spec.scenario},
        "aircraft": [
            {
                "sysid": k + 1,
                "serial": f"RSAF80000000{k + 1}",
                "start_enu_m": list(spec.benign[k](0.0)),
                "goal_enu_m": list(goals[k]),
                "cruise_alt_m": 60.0,
            }
            for k in range(n)
        ],
        "spoofer": None
        if spoofer_sysid is None
        else {"sysid": spoofer_sysid, "serial": SPOOFER_SERIAL, "offset_enu_m": [50, 50, 0]},
        "nmac_threshold_m": 50.0,
    }
    vehicles = [*spec.benign, *([spec.spoofer] if spec.spoofer is not None else [])]
    records: list[tuple[str, float, dict[str, Any]]] = [(topics.RUN_META, 0.0, meta)]
    for t in spec.truth_times():
        t_s = float(t)
        sysids = list(range(1, len(vehicles) + 1))
        records.append(
            (
                topics.TRUTH,
                t_s,
                {
                    "sysid": sysids,
                    "p_enu_m": [list(v(t_s)) for v in vehicles],
                    "v_enu_m_s": [[0.0, 0.0, 0.0] for _ in vehicles],
                    "armed": [spec.armed(s, t_s) for s in sysids],
                    "mode": [4 for _ in vehicles],
                    "spoofer_sysid": spoofer_sysid,
                    "spoofer_claimed_p_enu_m": None,
                },
            )
        )
    records.extend(spec.extra)
    if spec.end is not None:
        records.append((topics.RUN_END, spec.duration_s, spec.end))
    records.sort(key=lambda item: item[1])
    with McapRecorder(path) as recorder:
        for topic, t_s, record in records:
            recorder.log(topic, t_s, record)
    return path


def region(t_s: float, center: Sequence[float], cov: Any, uas_id: str = SPOOFER_SERIAL) -> Any:
    return (
        topics.REGIONS,
        t_s,
        {
            "uas_id": uas_id,
            "track_id": 1,
            "center_enu_m": [float(c) for c in center],
            "cov_enu_m2": np.asarray(cov, dtype=float).tolist(),
            "chi2_threshold": CHI2_95,
            "alpha": 0.05,
            "valid_until_s": t_s + 1.0,
            "semi_axes_m": [0.0, 0.0, 0.0],
        },
    )


def alert(t_s: float, uas_id: str = SPOOFER_SERIAL, state: str = "raised") -> Any:
    return (
        topics.ALERTS,
        t_s,
        {
            "uas_id": uas_id,
            "detector": "forced",
            "statistic": 1.0,
            "threshold": 0.0,
            "state": state,
        },
    )


def track(t_s: float, p: Sequence[float], uas_id: str = SPOOFER_SERIAL) -> Any:
    return (
        topics.TRACKS,
        t_s,
        {
            "uas_id": uas_id,
            "track_id": 1,
            "p_enu_m": [float(c) for c in p],
            "cov_enu_m2": np.eye(3).tolist(),
            "v_enu_m_s": [0.0, 0.0, 0.0],
            "mode_probabilities": [0.5, 0.5],
            "fix": True,
        },
    )


def metrics_of(tmp_path: Path, spec: RunSpec) -> dict[str, float | int | None]:
    return compute_metrics(write_run(tmp_path / "run.mcap", spec))


# A passes along x at y = 0, z = 60 m, 10 m/s, crossing x = 0 at t = 30 s.
PASSER = line((-300.0, 0.0, 60.0), (10.0, 0.0, 0.0))


def opposite(offset_y: float) -> Position:
    """Flies the other way at y = offset_y: closest to PASSER (= |offset_y|) at t = 30 s."""
    return line((300.0, offset_y, 60.0), (-10.0, 0.0, 0.0))


# --------------------------------------------------------------------------------------------
# Entry events


@pytest.mark.parametrize(("offset_y", "events"), [(40.0, 1), (60.0, 0), (49.9, 1), (50.0, 0)])
def test_benign_pair_passing_counts_one_event_below_threshold(
    tmp_path: Path, offset_y: float, events: int
) -> None:
    result = metrics_of(tmp_path, RunSpec([PASSER, opposite(offset_y)]))
    assert result["nmac_benign_benign"] == events
    assert result["nmac_benign_spoofer"] is None


def test_approach_separate_reapproach_counts_two_events(tmp_path: Path) -> None:
    # B hovers 40 m off A's track; A flies past it, turns round at t = 60 s and passes again.
    def back_and_forth(t: float) -> tuple[float, float, float]:
        x = -300.0 + 10.0 * t if t <= 60.0 else 300.0 - 10.0 * (t - 60.0)
        return (x, 0.0, 60.0)

    spec = RunSpec([back_and_forth, still((0.0, 40.0, 60.0))], duration_s=120.0)
    assert metrics_of(tmp_path, spec)["nmac_benign_benign"] == 2


def test_pair_on_the_ground_at_a_depot_is_no_nmac(tmp_path: Path) -> None:
    # Armed, 15 m apart, on the ground for the whole run: no encounter.
    spec = RunSpec([still((0.0, 0.0, 0.0)), still((15.0, 0.0, 0.0))])
    assert metrics_of(tmp_path, spec)["nmac_benign_benign"] == 0


def test_disarmed_aircraft_is_not_counted(tmp_path: Path) -> None:
    # A disarmed aircraft held at 60 m (a truth glitch): excluded like one on the ground.
    spec = RunSpec([PASSER, opposite(40.0)], armed=lambda sysid, t: sysid == 1)
    assert metrics_of(tmp_path, spec)["nmac_benign_benign"] == 0


def test_co_departure_counts_once_when_both_are_airborne(tmp_path: Path) -> None:
    # Two aircraft 15 m apart at a depot climb together at 2 m/s: one event (documented).
    def climb(x: float) -> Position:
        return lambda t: (x, 0.0, min(2.0 * max(t - 5.0, 0.0), 60.0))

    spec = RunSpec([climb(0.0), climb(15.0)])
    assert metrics_of(tmp_path, spec)["nmac_benign_benign"] == 1


@pytest.mark.parametrize(("offset_y", "events"), [(40.0, 1), (60.0, 0)])
def test_benign_spoofer_pass(tmp_path: Path, offset_y: float, events: int) -> None:
    result = metrics_of(tmp_path, RunSpec([PASSER], spoofer=opposite(offset_y)))
    assert result["nmac_benign_spoofer"] == events
    assert result["nmac_benign_benign"] == 0
    assert result["min_distance_to_spoofer_m"] == pytest.approx(offset_y)


def test_benign_on_the_ground_below_the_spoofer_is_no_nmac(tmp_path: Path) -> None:
    spoofer = line((-300.0, 0.0, 30.0), (10.0, 0.0, 0.0))
    result = metrics_of(tmp_path, RunSpec([still((0.0, 0.0, 0.0))], spoofer=spoofer))
    assert result["nmac_benign_spoofer"] == 0
    assert result["min_distance_to_spoofer_m"] is None  # no benign aircraft ever airborne


# --------------------------------------------------------------------------------------------
# Unsafe regions, containment, localisation


def test_an_aircraft_is_not_unsafe_inside_the_region_about_its_own_false_alert(
    tmp_path: Path,
) -> None:
    """A region raised about benign aircraft 1 (a false alert) follows aircraft 1: it is
    inside all along, but cannot leave itself. Aircraft 2 flying through it does count."""
    cov = 400.0 * np.eye(3)
    own = "RSAF800000001"
    extra = [region(t, (0.0, 0.0, 60.0), cov, uas_id=own) for t in np.arange(0.0, 60.0, 0.25)]
    extra.append(alert(0.0, uas_id=own))
    spec = RunSpec(
        [still((0.0, 0.0, 60.0)), line((-300.0, 0.0, 60.0), (10.0, 0.0, 0.0))],
        spoofer=still((900.0, 900.0, 60.0)),
        duration_s=60.0,
        extra=extra,
    )
    result = metrics_of(tmp_path, spec)
    assert result["unsafe_violations"] == 1  # aircraft 2's entry only
    assert result["false_alerts"] == 1
    # One false alert over two aircraft flying ~60 s: 1 / (2 * 60 / 3600) per aircraft-hour.
    assert result["false_alerts_per_aircraft_hour"] == pytest.approx(30.0, rel=0.02)


def test_unsafe_violations_count_entries_into_the_ellipsoid(tmp_path: Path) -> None:
    # Region: sphere of radius sqrt(7.81 * 400) = 56 m about (0, 0, 20), every 0.25 s.
    cov = 400.0 * np.eye(3)
    extra = [region(t, (0.0, 0.0, 20.0), cov) for t in np.arange(0.0, 120.0, 0.25)]

    def back_and_forth(t: float) -> tuple[float, float, float]:
        x = -300.0 + 10.0 * t if t <= 60.0 else 300.0 - 10.0 * (t - 60.0)
        return (x, 0.0, 60.0)

    spec = RunSpec(
        [
            back_and_forth,  # passes 40 m from the centre, twice: 2 entries
            line((-300.0, 60.0, 60.0), (10.0, 0.0, 0.0)),  # 72 m from the centre: none
            still((0.0, 10.0, 0.0)),  # 22 m from the centre, but on the ground: none
        ],
        spoofer=still((0.0, 0.0, 60.0)),
        duration_s=120.0,
        extra=extra,
    )
    assert metrics_of(tmp_path, spec)["unsafe_violations"] == 2


def _moving_spoofer() -> Position:
    return line((0.0, 0.0, 60.0), (7.0, 0.0, 0.0))


def test_containment_rate_uses_interpolated_truth_and_ignores_updates_before_alert(
    tmp_path: Path,
) -> None:
    spoofer = _moving_spoofer()
    tiny = 0.01 * np.eye(3)  # 0.28 m radius: nearest-sample truth (0.35 m off) would miss
    extra = [
        alert(3.0, uas_id="RSAF800000001"),  # someone else: ignored
        alert(5.0),
        region(4.05, (999.0, 0.0, 0.0), tiny),  # before the alert: ignored
        region(5.05, spoofer(5.05), tiny),
        region(5.30, spoofer(5.30), tiny),
        region(5.55, (spoofer(5.55)[0] + 200.0, 0.0, 60.0), tiny),  # misses
        region(5.80, spoofer(5.80), tiny),
    ]
    spec = RunSpec([still((500.0, 500.0, 60.0))], spoofer=spoofer, extra=extra)
    result = metrics_of(tmp_path, spec)
    assert result["containment_rate"] == pytest.approx(0.75)
    assert result["alert_time_s"] == pytest.approx(5.0)


def receptions(t_s: float, sender: int, receivers: Sequence[int]) -> Any:
    items = [{"sender": sender, "receiver": r, "msg_type": 1, "rssi_dbm": -70.0} for r in receivers]
    return (topics.RADIO_RX, t_s, {"items": items})


def test_detection_delay_counts_from_the_fourth_aircraft_that_heard_the_spoofer(
    tmp_path: Path,
) -> None:
    benign = [still((100.0 * k, 0.0, 60.0)) for k in range(5)]
    spoofer_sysid = 6
    extra = [
        receptions(1.0, 2, [1, 3, 4, 5]),  # a benign sender: not the spoofer
        receptions(1.5, spoofer_sysid, [1, 2]),
        receptions(2.5, spoofer_sysid, [1, 2, 3]),  # 1 and 2 again: three distinct so far
        receptions(4.0, spoofer_sysid, [5]),  # the fourth
        receptions(6.0, spoofer_sysid, [4]),
        alert(3.0, uas_id="RSAF800000001"),  # a benign aircraft flagged: a false alert
        alert(6.5),
        alert(7.0, uas_id="RSAF800000002", state="cleared"),  # not raised: not counted
    ]
    result = metrics_of(tmp_path, RunSpec(benign, spoofer=_moving_spoofer(), extra=extra))
    assert result["alert_time_s"] == pytest.approx(6.5)
    assert result["detection_delay_s"] == pytest.approx(6.5 - 4.0)
    assert result["false_alerts"] == 1


def test_detection_delay_is_null_until_four_aircraft_heard_the_spoofer(tmp_path: Path) -> None:
    benign = [still((100.0 * k, 0.0, 60.0)) for k in range(3)]
    extra = [receptions(1.0, 4, [1, 2, 3]), alert(2.0)]
    result = metrics_of(tmp_path, RunSpec(benign, spoofer=_moving_spoofer(), extra=extra))
    assert result["alert_time_s"] == pytest.approx(2.0)
    assert result["detection_delay_s"] is None
    assert result["false_alerts"] == 0


def test_rmse_and_mae_against_hand_computed_errors(tmp_path: Path) -> None:
    spoofer = _moving_spoofer()

    def est(t: float, dx: float, dy: float, dz: float) -> Any:
        p = spoofer(t)
        return track(t, (p[0] + dx, p[1] + dy, p[2] + dz))

    extra = [
        alert(5.0),
        est(4.0, 1000.0, 0.0, 0.0),  # before the alert
        est(5.0, 3.0, 0.0, 0.0),
        est(5.25, 0.0, 4.0, 0.0),
        est(5.5, 0.0, 0.0, 12.0),
        est(5.75, 3.0, 4.0, 0.0),  # |e| = 5
        track(5.75, (0.0, 0.0, 0.0), uas_id="RSAF800000001"),  # another track
    ]
    result = metrics_of(tmp_path, RunSpec([still((0.0, 500.0, 60.0))], spoofer, extra=extra))
    # errors 3, 4, 12, 5: RMSE = sqrt((9 + 16 + 144 + 25) / 4), MAE = 24 / 4
    assert result["rmse_m"] == pytest.approx(math.sqrt(194.0 / 4.0))
    assert result["mae_m"] == pytest.approx(6.0)
    series = metric_series(tmp_path / "run.mcap")
    assert series.localisation_error_m == pytest.approx([3.0, 4.0, 12.0, 5.0])


def test_max_ellipsoid_radius_for_a_rotated_covariance(tmp_path: Path) -> None:
    c, s = math.cos(0.4), math.sin(0.4)
    rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    cov = rotation @ np.diag([100.0, 400.0, 25.0]) @ rotation.T
    extra = [alert(5.0), region(5.0, (0, 0, 60), cov), region(5.25, (0, 0, 60), 9.0 * np.eye(3))]
    result = metrics_of(tmp_path, RunSpec([still((0, 500, 60))], _moving_spoofer(), extra=extra))
    assert result["max_ellipsoid_radius_m"] == pytest.approx(20.0 * math.sqrt(CHI2_95))


# --------------------------------------------------------------------------------------------
# Goals, cost, nulls


def test_goal_reached_fraction_uses_horizontal_distance_and_the_arrival_radius(
    tmp_path: Path,
) -> None:
    a = line((0.0, 0.0, 60.0), (5.0, 0.0, 0.0))  # ends at (300, 0, 60)
    b = line((0.0, 100.0, 60.0), (5.0, 0.0, 0.0))  # ends at (300, 100, 60)
    goals = [(305.0, 0.0, 0.0), (315.0, 100.0, 0.0)]  # 5 m and 15 m short (horizontally)
    assert metrics_of(tmp_path, RunSpec([a, b], goals=goals))["goal_reached_fraction"] == 0.5
    wide = RunSpec([a, b], goals=goals, scenario={"companion": {"arrival_radius_m": 20.0}})
    assert compute_metrics(write_run(tmp_path / "wide.mcap", wide))["goal_reached_fraction"] == 1.0


def test_landed_fraction_counts_touch_downs_on_the_site_after_arriving(tmp_path: Path) -> None:
    def arrive_then_descend(rate_m_s: float, drift_m_s: float = 0.0) -> Position:
        """Arrives over (100, 0, 40) at 20 s, then sinks at ``rate_m_s`` (stops at 0),
        drifting east at ``drift_m_s``."""
        return lambda t: (
            min(5.0 * t, 100.0) + drift_m_s * max(t - 20.0, 0.0),
            0.0,
            max(40.0 - rate_m_s * max(t - 20.0, 0.0), 0.0),
        )

    lands = arrive_then_descend(1.0)  # on the ground over its site at 60 s
    sinks_slowly = arrive_then_descend(0.5)  # 10 m up at the end
    hovers = arrive_then_descend(0.0)
    pushed_off = arrive_then_descend(1.0, drift_m_s=0.5)  # down 20 m beside its site
    down_short = still((0.0, 0.0, 0.0))  # on the ground, never arrives
    aircraft = [lands, sinks_slowly, hovers, pushed_off, down_short]
    spec = RunSpec(aircraft, duration_s=80.0, goals=[(100.0, 0.0, 0.0)] * 5)
    metrics = metrics_of(tmp_path, spec)
    assert metrics["goal_reached_fraction"] == 0.8
    assert metrics["landed_fraction"] == 0.2
    disarmed = dataclasses.replace(spec, armed=lambda sysid, t: not (sysid == 3 and t > 30.0))
    assert compute_metrics(write_run(tmp_path / "b.mcap", disarmed))["landed_fraction"] == 0.4


def test_cost_metrics_and_percentiles(tmp_path: Path) -> None:
    cycles = [
        (
            topics.GCS_CYCLE,
            0.25 * k,
            {"compute_ms": float(k), "n_observations": 0, "n_transmissions": 0, "n_tracks": 0},
        )
        for k in range(1, 101)
    ]
    decisions = [
        (topics.DECISIONS, 0.5 * k, {"sysid": 1, "compute_ms": float(k)}) for k in range(1, 11)
    ]
    end = {"wall_clock_s": 12.5, "sim_time_s": 60.0, "status": "completed", "reason": ""}
    spec = RunSpec([PASSER], extra=cycles + decisions, end=end)
    result = metrics_of(tmp_path, spec)
    assert result["gcs_compute_s"] == pytest.approx(5.05)  # 5050 ms
    assert result["gcs_update_p99_ms"] == pytest.approx(99.01)  # 99 + 0.01 (100 - 99)
    assert result["planner_decision_p99_ms"] == pytest.approx(9.91)  # 9 + 0.91 (10 - 9)
    assert result["wall_clock_s"] == 12.5


def test_without_spoofer_the_spoofer_metrics_are_null(tmp_path: Path) -> None:
    result = metrics_of(tmp_path, RunSpec([PASSER, opposite(40.0)]))
    assert list(result) == list(METRIC_KEYS)
    for key in (
        "nmac_benign_spoofer",
        "unsafe_violations",
        "containment_rate",
        "rmse_m",
        "mae_m",
        "max_ellipsoid_radius_m",
        "min_distance_to_spoofer_m",
        "alert_time_s",
        "wall_clock_s",
        "gcs_compute_s",
        "gcs_update_p99_ms",
        "planner_decision_p99_ms",
    ):
        assert result[key] is None, key
    assert result["nmac_benign_benign"] == 1
    json.dumps(result)  # plain Python numbers only


def test_spoofer_without_alert_gives_null_localisation_metrics(tmp_path: Path) -> None:
    extra = [track(5.0, (0.0, 0.0, 60.0))]
    result = metrics_of(tmp_path, RunSpec([PASSER], _moving_spoofer(), extra=extra))
    assert result["alert_time_s"] is None
    assert result["containment_rate"] is None
    assert result["rmse_m"] is None
    assert result["nmac_benign_spoofer"] == 0


def test_metric_series_min_distance(tmp_path: Path) -> None:
    path = write_run(tmp_path / "run.mcap", RunSpec([PASSER], spoofer=opposite(40.0)))
    series = metric_series(path)
    assert series.t_s.shape == series.min_distance_to_spoofer_m.shape == (601,)
    k = int(np.argmin(series.min_distance_to_spoofer_m))
    assert series.t_s[k] == pytest.approx(30.0)
    assert series.min_distance_to_spoofer_m[0] == pytest.approx(math.hypot(600.0, 40.0))


def test_metrics_of_a_truncated_log_cover_what_was_written(tmp_path: Path) -> None:
    path = write_run(tmp_path / "run.mcap", RunSpec([PASSER, opposite(40.0)], duration_s=120.0))
    cut = tmp_path / "cut.mcap"
    shutil.copyfile(path, cut)
    with open(cut, "r+b") as stream:
        stream.truncate(path.stat().st_size // 2)
    run = load_run(cut)
    assert 0 < run.truth.t_s.size < 1201
    assert np.all(np.diff(run.truth.t_s) > 0)


# --------------------------------------------------------------------------------------------
# The command line


def _cli(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    parser = argparse.ArgumentParser(prog="ridsafe")
    metrics_cmd.register(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["metrics", *argv])
    code: int = args.func(args)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_cli_prints_json_and_a_table(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = write_run(tmp_path / "run.mcap", RunSpec([PASSER], spoofer=opposite(40.0)))
    code, out, _err = _cli([str(path), "--json"], capsys)
    assert code == 0
    printed = json.loads(out)
    assert list(printed) == list(METRIC_KEYS)
    assert printed["nmac_benign_spoofer"] == 1
    code, out, _err = _cli([str(path)], capsys)
    assert code == 0
    assert "NMAC benign-spoofer" in out
    assert "n/a" in out  # no alert, no regions


@pytest.mark.parametrize(
    "content", [b"", b"not an mcap file at all", b"\x89MCAP0\r\n" + bytes(40), None]
)
def test_cli_rejects_a_bad_file_with_exit_code_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], content: bytes | None
) -> None:
    path = tmp_path / "bad.mcap"
    if content is not None:
        path.write_bytes(content)
    code, out, err = _cli([str(path)], capsys)
    assert code == 1
    assert out == ""
    assert "bad.mcap" in err


@pytest.mark.parametrize(
    ("alert_s", "region_times_s", "expected_s"),
    [
        (10.0, [8.0, 12.5, 13.0], 2.5),  # a region before the alert does not count
        (10.0, [], 50.0),  # alerted, never a region: the truth's end (60 s) minus the alert
        (10.0, [5.0], 50.0),  # only a region before the alert: the same
        (None, [12.5], None),  # no alert
    ],
)
def test_region_delay_counts_from_the_alert_to_the_first_region_after_it(
    tmp_path: Path, alert_s: float | None, region_times_s: list[float], expected_s: float | None
) -> None:
    extra = [region(t, (0.0, 0.0, 60.0), 100.0 * np.eye(3)) for t in region_times_s]
    if alert_s is not None:
        extra.append(alert(alert_s))
    spec = RunSpec([PASSER], spoofer=still((0.0, 0.0, 60.0)), extra=extra)
    result = metrics_of(tmp_path, spec)["region_delay_s"]
    assert result == (None if expected_s is None else pytest.approx(expected_s))
