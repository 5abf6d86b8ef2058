"""The paper's metric definitions (``analysis/paper_metrics.py``) on hand-built run logs, each
case one where the authors' definition and ours give different numbers, worked out by hand."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ridsafe.tools.analysis.paper_metrics import PAPER_METRIC_KEYS
from tests.tools.analysis.test_metrics import (
    CHI2_95,
    PASSER,
    RunSpec,
    alert,
    line,
    metrics_of,
    region,
    still,
    track,
)

SPOOFER_AT = (0.0, 0.0, 60.0)
COV_100 = np.eye(3) * 100.0


def _regions(start_s: float, end_s: float, center: tuple[float, float, float]) -> list[Any]:
    times = np.round(np.arange(start_s, end_s + 1e-9, 0.25), 10)
    return [region(float(t), center, COV_100) for t in times]


def test_keys_are_reported() -> None:
    assert all(k.startswith("paper_") for k in PAPER_METRIC_KEYS)


def test_mean_radius_counts_zero_before_the_first_region(tmp_path: Path) -> None:
    # 60 s: ticks 0.25 .. 60 (240); regions from 30 s: at 121 of them.
    spec = RunSpec(
        benign=[still((1000.0, 0.0, 60.0))],
        spoofer=still(SPOOFER_AT),
        extra=[alert(30.0), *_regions(30.0, 60.0, SPOOFER_AT)],
    )
    m = metrics_of(tmp_path, spec)
    semi_axis = math.sqrt(CHI2_95 * 100.0)
    assert m["max_ellipsoid_radius_m"] == pytest.approx(semi_axis)
    assert m["paper_mean_ellipsoid_radius_m"] == pytest.approx(semi_axis * 121 / 240)
    assert m["paper_containment_rate"] == 1.0


def test_horizontal_radius_leaves_the_vertical_axis_out(tmp_path: Path) -> None:
    # std 10 m north, 20 m up, from 30 s of 60 s: the largest axis is vertical, the largest
    # horizontal one 10 m std, each over 121 of the 240 ticks.
    cov = np.diag([25.0, 100.0, 400.0])
    times = np.round(np.arange(30.0, 60.0 + 1e-9, 0.25), 10)
    spec = RunSpec(
        benign=[still((1000.0, 0.0, 60.0))],
        spoofer=still(SPOOFER_AT),
        extra=[alert(30.0), *(region(float(t), SPOOFER_AT, cov) for t in times)],
    )
    m = metrics_of(tmp_path, spec)
    assert m["paper_mean_ellipsoid_radius_m"] == pytest.approx(math.sqrt(CHI2_95 * 400) * 121 / 240)
    assert m["paper_mean_horizontal_radius_m"] == pytest.approx(
        math.sqrt(CHI2_95 * 100) * 121 / 240
    )


def test_rmse_is_of_the_region_centre_not_the_track(tmp_path: Path) -> None:
    spec = RunSpec(
        benign=[still((1000.0, 0.0, 60.0))],
        spoofer=still(SPOOFER_AT),
        extra=[
            alert(10.0),
            *_regions(10.0, 60.0, (30.0, 40.0, 60.0)),
            *[track(float(t), SPOOFER_AT) for t in np.arange(10.0, 60.0, 0.25)],
        ],
    )
    m = metrics_of(tmp_path, spec)
    assert m["rmse_m"] == 0.0
    assert m["paper_rmse_m"] == pytest.approx(50.0)
    assert m["paper_mae_m"] == pytest.approx(50.0)


def test_an_aircraft_at_its_goal_no_longer_counts(tmp_path: Path) -> None:
    # A hovers on its goal (arrived at t = 0); PASSER flies 20 m past it at t = 30 s.
    spec = RunSpec(
        benign=[still((0.0, 20.0, 60.0)), PASSER],
        goals=[(0.0, 20.0, 60.0), (5000.0, 0.0, 60.0)],
    )
    m = metrics_of(tmp_path, spec)
    assert m["nmac_benign_benign"] == 1
    assert m["paper_nmac_benign_benign"] == 0


def test_pass_before_arrival_still_counts(tmp_path: Path) -> None:
    # The same pass, but A reaches its goal (x = 400 m) only after it.
    spec = RunSpec(
        benign=[
            line((0.0, 20.0, 60.0), (10.0, 0.0, 0.0)),
            line((60.0, 0.0, 60.0), (0.0, 0.0, 0.0)),
        ],
        goals=[(400.0, 20.0, 60.0), (5000.0, 0.0, 60.0)],
    )
    m = metrics_of(tmp_path, spec)
    assert m["nmac_benign_benign"] == m["paper_nmac_benign_benign"] == 1


def test_violations_count_per_aircraft_over_all_regions(tmp_path: Path) -> None:
    # Two overlapping regions (two uas_ids) on PASSER's path: ours counts an entry into
    # each (2), the paper one entry into "any region" (1).
    extra: list[Any] = [alert(0.0)]
    for t in np.round(np.arange(0.0, 60.0 + 1e-9, 0.25), 10):
        extra.append(region(float(t), (0.0, 0.0, 60.0), COV_100))
        extra.append(region(float(t), (5.0, 0.0, 60.0), COV_100, uas_id="RSAF800000777"))
    spec = RunSpec(benign=[PASSER], spoofer=still((0.0, 500.0, 60.0)), extra=extra)
    m = metrics_of(tmp_path, spec)
    assert m["unsafe_violations"] == 2
    assert m["paper_unsafe_violations"] == 1
