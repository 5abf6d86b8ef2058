"""Faults injected into a lockstep run: a core that dies, a GCS that restarts (issue 14).

A lockstep run's router holds its cores by name (``lockstep.SIM``, ``lockstep.GCS``,
``lockstep.companion_core(sysid)``); ``kill`` puts a ``DeadCore`` in one's place (it takes
every datagram and answers none, as a crashed process whose port still exists), and
``measure_gcs_restart`` kills the GCS, starts a fresh one from the factory in its place (new
state, a signing stream that follows time, as a restarted ``ridsafe gcs``) and measures how
long it takes to serve the companions the spoofer's unsafe region again:

- ``first_report_s``: the first observation report the new GCS accepts;
- ``first_region_s``: the first unsafe region of a spoofer from the new GCS that a companion
  takes (its ``region ... new`` event: the old GCS's regions have expired by then);
- ``reacquire_s = first_region_s - first_report_s``: the issue's bar is 10 s.

``fly_with_kills`` flies a whole lockstep run to a log, with cores killed at given times (a
companion that dies: its aircraft must land by the autopilot's companion-loss failsafe, and
the metrics count it).

``bench/bench_gcs_restart.py`` prints it for several seeds;
``tests/tools/run/test_gcs_restart.py`` holds it to the bar.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from ridsafe.common import topics
from ridsafe.common.logsink import Record
from ridsafe.common.shell import Datagrams
from ridsafe.tools.run import cores, lockstep, process, run_records
from ridsafe.tools.run.scenario import ScenarioFile

__all__ = [
    "DeadCore",
    "GcsRestart",
    "TopicSink",
    "fly_with_kills",
    "kill",
    "measure_gcs_restart",
]


class DeadCore:
    """A core that is not there: takes everything, answers nothing."""

    def handle(self, now_s: float, inbound: Datagrams) -> Datagrams:
        return []


def kill(run: lockstep.Lockstep, core: str) -> None:
    """Replace the core named ``core`` in ``run``'s router by a ``DeadCore``."""
    if core not in run.router.cores:
        raise KeyError(f"no core {core!r} in this run (have {sorted(run.router.cores)})")
    run.router.cores[core] = DeadCore()


def fly_with_kills(
    loaded: ScenarioFile, planner: str, log_path: Path, kills: Mapping[str, float]
) -> None:
    """Fly ``loaded`` in lockstep for its duration, logging to ``log_path`` as ``ridsafe run
    --mode lockstep`` does, with each core of ``kills`` (name -> sim time) killed then."""
    wall_start = time.perf_counter()
    log = process.open_run_log(log_path, loaded.scenario.origin, foxglove=False)
    with log as recorder:
        run_records.log_meta(recorder, run_records.run_meta(loaded, "lockstep", planner))
        run = lockstep.build(loaded, planner, recorder)
        due = sorted(kills.items(), key=lambda kill_at: kill_at[1])
        while run.t_s < loaded.scenario.duration_s - 1e-9:
            while due and run.t_s >= due[0][1] - 1e-9:
                kill(run, due.pop(0)[0])
            run.step()
        run.finish()
        wall = time.perf_counter() - wall_start
        end = run_records.run_end(wall, run.t_s, "completed", "")
        recorder.log(topics.RUN_END, run.t_s, end)


@dataclass
class TopicSink:
    """Keeps the records of ``topics`` only: (topic, t_s, record) in order."""

    topics: frozenset[str]
    records: list[tuple[str, float, Record]] = field(default_factory=list)

    def log(self, topic: str, t_s: float, record: Record) -> None:
        if topic in self.topics:
            self.records.append((topic, t_s, record))


@dataclass(frozen=True)
class GcsRestart:
    """One GCS restart in a lockstep run, times in sim seconds (module docstring)."""

    seed: int
    killed_at_s: float
    restarted_at_s: float
    first_report_s: float | None
    first_region_s: float | None
    served_before_kill: int  # companions that took a spoofer region from the first GCS
    companions_served: int  # companions that took a spoofer region from the new GCS
    companions: int

    @property
    def reacquire_s(self) -> float | None:
        if self.first_report_s is None or self.first_region_s is None:
            return None
        return self.first_region_s - self.first_report_s

    def line(self) -> str:
        reacquire = "never" if self.reacquire_s is None else f"{self.reacquire_s:5.2f} s"
        report = "none" if self.first_report_s is None else f"{self.first_report_s:6.2f} s"
        return (
            f"seed {self.seed}: GCS killed at {self.killed_at_s:g} s, restarted at "
            f"{self.restarted_at_s:g} s; first report {report}; spoofer region re-acquired "
            f"{reacquire} after it, taken by {self.companions_served}/{self.companions} "
            "companions"
        )


def _spoofer_regions_taken(
    records: list[tuple[str, float, Record]], spoofers: set[str], after_s: float
) -> list[tuple[float, int]]:
    """(time, sysid) of each companion's ``region ... new`` event for a spoofer after
    ``after_s``."""
    taken = []
    for topic, t_s, record in records:
        if topic != topics.COMPANION_EVENTS or t_s <= after_s or record["event"] != "region":
            continue
        if record.get("uas_id") in spoofers and str(record["detail"]).endswith(": new"):
            taken.append((t_s, int(record["sysid"])))
    return taken


def measure_gcs_restart(
    loaded: ScenarioFile,
    planner: str,
    killed_at_s: float,
    restarted_at_s: float,
    until_s: float,
) -> GcsRestart:
    """Fly ``loaded`` in lockstep, kill the GCS at ``killed_at_s``, start a new one at
    ``restarted_at_s``, fly on to ``until_s``; what the restart cost (module docstring)."""
    if not 0.0 < killed_at_s <= restarted_at_s < until_s:
        raise ValueError(
            f"expected 0 < killed_at_s <= restarted_at_s < until_s, got "
            f"{killed_at_s}, {restarted_at_s}, {until_s}"
        )
    sink = TopicSink(frozenset({topics.COMPANION_EVENTS}))
    run = lockstep.build(loaded, planner, sink)
    while run.t_s < killed_at_s - 1e-9:
        run.step()
    kill(run, lockstep.GCS)
    while run.t_s < restarted_at_s - 1e-9:
        run.step()
    gcs = cores.make_gcs(loaded, sink, lockstep.lockstep_signing(loaded))
    run.router.cores[lockstep.GCS] = gcs
    first_report_s = None
    while run.t_s < until_s - 1e-9:
        run.step()
        if first_report_s is None and gcs.ingest.counters.accepted:
            first_report_s = run.t_s
    spoofers = {s.serial for s in loaded.scenario.all_spoofers}
    before = _spoofer_regions_taken(sink.records, spoofers, 0.0)
    taken = _spoofer_regions_taken(sink.records, spoofers, restarted_at_s)
    return GcsRestart(
        seed=loaded.scenario.seed,
        killed_at_s=killed_at_s,
        restarted_at_s=restarted_at_s,
        first_report_s=first_report_s,
        first_region_s=min((t for t, _ in taken), default=None),
        served_before_kill=len({sysid for t_s, sysid in before if t_s < killed_at_s}),
        companions_served=len({sysid for _, sysid in taken}),
        companions=len(run.companions),
    )
