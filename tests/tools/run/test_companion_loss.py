"""A killed companion's aircraft lands by itself, in a whole run (issue 14's Done-when): the
default scenario in lockstep, companion 2 killed in the air; its autopilot's companion-loss
failsafe (``sim.autopilot.companion_loss_timeout_s``, LAND by default) brings it down and
disarms it, the metrics count the failsafe, and the other aircraft still deliver. The
failsafe's own rules (timeout, RTL, hold, off) are tested in
``tests/sim_backend/test_failsafe.py``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ridsafe.tools.analysis.metrics import arrival_times_s, compute_metrics
from ridsafe.tools.analysis.run_arrays import load_run
from ridsafe.tools.run import faults, lockstep
from ridsafe.tools.run.scenario import load_scenario_file

KILLED_AT_S = 30.0  # companion 2 is in the air (climbing to its 60 m cruise)


def test_a_killed_companions_aircraft_lands_by_itself_and_the_metrics_count_it(
    tmp_path: Path,
) -> None:
    loaded = load_scenario_file(None)
    path = tmp_path / "run.mcap"
    faults.fly_with_kills(loaded, "straight-line", path, {lockstep.companion_core(2): KILLED_AT_S})
    run = load_run(path)
    metrics = compute_metrics(run)
    assert metrics["autopilot_failsafes"] == 1
    column = run.truth.column(2)
    assert column is not None
    at_kill = int(np.searchsorted(run.truth.t_s, KILLED_AT_S))
    assert run.truth.p_enu_m[at_kill, column, 2] > 20.0 and run.truth.armed[at_kill, column]
    landed = np.flatnonzero(~run.truth.armed[at_kill:, column])
    assert landed.size, "never disarmed"
    landed_s = run.truth.t_s[at_kill + landed[0]]
    assert landed_s < loaded.scenario.duration_s
    assert run.truth.p_enu_m[-1, column, 2] < 0.5
    assert not run.truth.armed[at_kill + landed[0] :, column].any()  # and stays down
    arrivals = arrival_times_s(run)
    assert arrivals[2] is None
    assert all(arrivals[sysid] is not None for sysid in (1, 3, 4))
    assert metrics["goal_reached_fraction"] == 0.75
