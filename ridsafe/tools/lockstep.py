"""Lockstep runs: every core of a scenario in one process, advanced by one clock.

The sim backend, one companion per benign aircraft and the GCS exchange the same MAVLink
bytes they exchange over UDP, through ``ByteRouter`` in a fixed order (sim, companions in
system-id order, GCS), every ``run.lockstep_tick_s`` of sim time, as fast as the CPU allows.
Randomness comes only from the scenario seed and the signing key is derived from it, so the
same scenario and seed give the same log content.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ridsafe.common import topics
from ridsafe.common.heard import RidFrameDecoder
from ridsafe.common.logsink import LogSink, NullSink
from ridsafe.common.router import ByteRouter, Wire
from ridsafe.common.shell import SansIoCore
from ridsafe.companion.companion import Companion
from ridsafe.gcs.gcs import Gcs, peer_endpoint
from ridsafe.sim_backend.world import EndpointKind, SimBackend, endpoint_name
from ridsafe.tools import assemble
from ridsafe.tools.scenario import ScenarioFile

logger = logging.getLogger(__name__)

SIM = "sim"
GCS = "gcs"


def companion_core(sysid: int) -> str:
    return f"companion/{sysid}"


def lockstep_peer(sysid: int) -> str:
    """The GCS's name for companion ``sysid``'s link in a lockstep run."""
    return f"c{sysid}"


@dataclass
class Lockstep:
    """The cores of one lockstep run and the router between them."""

    sim: SimBackend
    companions: dict[int, Companion]
    gcs: Gcs
    router: ByteRouter
    tick_s: float
    ticks: int = 0

    @property
    def t_s(self) -> float:
        return self.ticks * self.tick_s

    def step(self) -> float:
        self.ticks += 1
        now_s = self.ticks * self.tick_s  # whole ticks: no drift
        self.router.step(now_s)
        return now_s

    def finish(self) -> None:
        for companion in self.companions.values():
            companion.finish(self.t_s)
        self.gcs.finish(self.t_s)


def build(loaded: ScenarioFile, planner: str, sink: LogSink) -> Lockstep:
    signing = assemble.signing_for_lockstep(loaded)
    sim = assemble.make_sim(loaded, sink)
    decoder = RidFrameDecoder()  # shared: each broadcast is decoded once, not per receiver
    companions = {
        sysid: assemble.make_companion(loaded, sysid, planner, sink, signing, decoder)
        for sysid in assemble.companion_ids(loaded)
    }
    gcs = assemble.make_gcs(loaded, sink, signing)
    cores: dict[str, SansIoCore] = {SIM: sim, GCS: gcs}
    wires = []
    for sysid, companion in companions.items():
        cores[companion_core(sysid)] = companion
        autopilot_port = (SIM, endpoint_name(sysid, EndpointKind.COMPANION))
        wires.append(Wire(autopilot_port, (companion_core(sysid), "autopilot")))
        gcs_port = (GCS, peer_endpoint(lockstep_peer(sysid)))
        wires.append(Wire(gcs_port, (companion_core(sysid), "gcs")))
    order = [SIM, *(companion_core(sysid) for sysid in companions), GCS]
    router = ByteRouter(cores, wires, order)
    return Lockstep(sim, companions, gcs, router, loaded.run.lockstep_tick_s)


def warm_up(loaded: ScenarioFile, planner: str) -> float:
    """Build the scenario's cores once and advance them one tick, logging nothing, so every
    numba kernel a run uses is compiled into (or loaded from) the cache; returns the wall
    time (s). A live run calls this before it starts its processes: after an install they
    would otherwise each compile the same kernels (~30 s on 2 cores) while the clock runs."""
    wall_start = time.perf_counter()
    build(loaded, planner, NullSink()).step()
    return time.perf_counter() - wall_start


@dataclass(frozen=True)
class RunResult:
    status: str
    reason: str
    wall_clock_s: float
    sim_time_s: float
    log_path: Path
    build_s: float = 0.0  # of wall_clock_s: building the cores (kernels loaded) before t = 0


def run_lockstep(
    loaded: ScenarioFile,
    planner: str,
    log_path: Path,
    on_progress: Callable[[float], None] | None = None,
    recorder_process: bool = True,
) -> RunResult:
    """Fly the scenario for its duration, logging to ``log_path``; Ctrl-C ends it early
    with a valid log. ``recorder_process``: write the log from a child process (on the other
    core; the same file), else from this one (a sweep's workers already use every core)."""
    from ridsafe.tools.recorder import McapRecorder  # noqa: PLC0415 (mcap only here)
    from ridsafe.tools.recorder_process import RecorderProcess  # noqa: PLC0415

    log_path.parent.mkdir(parents=True, exist_ok=True)
    wall_start = time.perf_counter()
    status, reason = "completed", ""
    foxglove = loaded.run.foxglove_channels
    origin = loaded.scenario.origin
    sink = RecorderProcess if recorder_process else McapRecorder
    with sink(log_path, origin=origin, foxglove=foxglove) as recorder:
        assemble.log_meta(recorder, assemble.run_meta(loaded, "lockstep", planner))
        build_start = time.perf_counter()
        run = build(loaded, planner, recorder)
        build_s = time.perf_counter() - build_start
        duration = loaded.scenario.duration_s
        try:
            while run.t_s < duration - 1e-9:
                now_s = run.step()
                if on_progress is not None:
                    on_progress(now_s)
        except KeyboardInterrupt:
            status, reason = "interrupted", "Ctrl-C"
        run.finish()
        wall = time.perf_counter() - wall_start
        recorder.log(topics.RUN_END, run.t_s, assemble.run_end(wall, run.t_s, status, reason))
    return RunResult(status, reason, wall, run.t_s, log_path, build_s)
