"""The depot jam of dense traffic, reproduced small: aircraft parked on the pads around a
departing aircraft broadcast Remote ID from the ground, and the planner, taking them for
traffic, crawls off its pad (at 64 aircraft a depot holds up to 21 parked aircraft; leaving
took 17 s on average and up to 48 s, against 11 s alone). With
``companion.ignore_grounded_traffic`` they are left out and the delivery is on time.

The run is deterministic (lockstep, no shadowing): the same arrival every time.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from ridsafe.common.config import load_config
from ridsafe.tools.analysis.metrics import arrival_times_s
from ridsafe.tools.analysis.run_arrays import load_run
from ridsafe.tools.run.lockstep import run_lockstep
from ridsafe.tools.run.scenario import ScenarioFile

DEPOT_JAM = Path(__file__).with_name("depot_jam.yaml")
NOMINAL_ARRIVAL_S = 4.0 + 300.0 / 8.0  # take-off, then 300 m at 8 m/s


def _arrival_s(tmp_path: Path, ignore_grounded: bool) -> float | None:
    loaded = load_config(DEPOT_JAM, ScenarioFile)
    companion = dataclasses.replace(loaded.companion, ignore_grounded_traffic=ignore_grounded)
    loaded = dataclasses.replace(loaded, companion=companion)
    out = tmp_path / f"grounded-{ignore_grounded}.mcap"
    run_lockstep(loaded, "aware", out, recorder_process=False)
    return arrival_times_s(load_run(out)).get(1)


@pytest.mark.slow
def test_parked_aircraft_jam_the_departure_unless_left_out(tmp_path: Path) -> None:
    jammed = _arrival_s(tmp_path, ignore_grounded=False)
    free = _arrival_s(tmp_path, ignore_grounded=True)
    assert free is not None and free <= NOMINAL_ARRIVAL_S + 6.0
    assert jammed is None or jammed >= free + 5.0  # today: 53.7 s against 45.4 s
