"""A GCS that dies and restarts re-acquires the spoofer within 10 s of the first reports it
gets (issue 14; measured in lockstep with the default scenario by ``tools.run.faults``,
printed with ``pytest -s`` and, for several seeds, by ``bench/bench_gcs_restart.py``). Its
signing stream follows time (``SigningState.advance_to``), so the companions take the new
GCS's packets as fresh, and their own streams, which also follow time, are fresh to it."""

from __future__ import annotations

import pytest

from ridsafe.common.shell import Datagrams
from ridsafe.tools.run import faults, lockstep
from ridsafe.tools.run.scenario import load_scenario_file

KILLED_AT_S, RESTARTED_AT_S, UNTIL_S = 40.0, 45.0, 70.0
REACQUIRE_BAR_S = 10.0


def test_a_restarted_gcs_reacquires_the_spoofer_within_10_s_of_the_first_reports() -> None:
    loaded = load_scenario_file(None)
    restart = faults.measure_gcs_restart(loaded, "aware", KILLED_AT_S, RESTARTED_AT_S, UNTIL_S)
    print(restart.line())
    assert restart.served_before_kill == restart.companions == 4  # it had the spoofer before
    assert restart.first_report_s is not None
    assert restart.first_report_s - RESTARTED_AT_S < 1.0
    assert restart.reacquire_s is not None and restart.reacquire_s <= REACQUIRE_BAR_S
    assert restart.companions_served == restart.companions  # every companion takes its regions


def test_a_killed_core_takes_everything_and_answers_nothing() -> None:
    run = lockstep.build(load_scenario_file(None), "straight-line", faults.TopicSink(frozenset()))
    faults.kill(run, lockstep.companion_core(2))
    dead = run.router.cores[lockstep.companion_core(2)]
    inbound: Datagrams = [("autopilot", b"\xfd\x00")]
    assert dead.handle(0.0, inbound) == []
    with pytest.raises(KeyError, match="no core 'nope'"):
        faults.kill(run, "nope")


def test_the_restart_times_must_be_in_order() -> None:
    with pytest.raises(ValueError, match="killed_at_s <= restarted_at_s"):
        faults.measure_gcs_restart(load_scenario_file(None), "aware", 10.0, 5.0, 20.0)
