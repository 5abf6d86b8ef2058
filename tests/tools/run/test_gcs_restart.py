"""A GCS that dies and restarts re-acquires the spoofer within 10 s of the first reports it
gets (issue 14; measured here in lockstep with the default scenario). Its signing stream
follows time (``SigningState.advance_to``), so the companions take the new GCS's packets as
fresh, and their own streams, which also follow time, are fresh to it."""

from __future__ import annotations

from ridsafe.common.logsink import NullSink
from ridsafe.common.shell import Datagrams
from ridsafe.tools.run import cores, lockstep
from ridsafe.tools.run.scenario import load_scenario_file

KILLED_AT_S, RESTARTED_AT_S, UNTIL_S = 40.0, 45.0, 70.0


class DeadCore:
    """A core that is not there: takes everything, answers nothing."""

    def handle(self, now_s: float, inbound: Datagrams) -> Datagrams:
        return []


def test_a_restarted_gcs_reacquires_the_spoofer_within_10_s_of_the_first_reports() -> None:
    loaded = load_scenario_file(None)
    run = lockstep.build(loaded, "aware", NullSink())
    while run.t_s < KILLED_AT_S - 1e-9:
        run.step()
    assert run.gcs.counters.regions_sent > 0
    run.router.cores[lockstep.GCS] = DeadCore()
    while run.t_s < RESTARTED_AT_S - 1e-9:
        run.step()
    received_before = {s: c.regions.counters.received for s, c in run.companions.items()}
    gcs = cores.make_gcs(loaded, NullSink(), lockstep.lockstep_signing(loaded))
    run.router.cores[lockstep.GCS] = gcs
    first_report_s = first_region_s = None
    while run.t_s < UNTIL_S - 1e-9:
        run.step()
        if first_report_s is None and gcs.ingest.counters.accepted:
            first_report_s = run.t_s
        if first_region_s is None and gcs.counters.regions_sent:
            first_region_s = run.t_s
    assert first_report_s is not None and first_region_s is not None
    assert first_report_s - RESTARTED_AT_S < 1.0
    assert first_region_s - first_report_s <= 10.0
    for sysid, companion in run.companions.items():  # and the companions take its regions
        assert companion.regions.counters.received > received_before[sysid]
