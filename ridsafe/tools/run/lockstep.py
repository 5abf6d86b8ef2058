"""Lockstep runs: every core of a scenario in one process, advanced by one clock.

The sim backend, one companion per benign aircraft and the GCS exchange the same MAVLink
bytes they exchange over UDP, through ``ByteRouter`` in a fixed order (sim, companions in
system-id order, GCS), every ``run.lockstep_tick_s`` of sim time, as fast as the CPU allows.
Randomness comes only from the scenario seed and the signing key is derived from it, so the
same scenario and seed give the same log content.
"""

from __future__ import annotations

import functools
import gc
import hashlib
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ridsafe.common import codec, topics
from ridsafe.common.logsink import LogSink, NullSink, TeeSink
from ridsafe.common.router import ByteRouter, Wire
from ridsafe.common.runner import freeze_startup_objects
from ridsafe.common.shell import SansIoCore
from ridsafe.companion.companion import Companion
from ridsafe.gcs.gcs import Gcs, peer_endpoint
from ridsafe.sim_backend.world import EndpointKind, SimBackend, endpoint_name
from ridsafe.tools.run import cores, lockstep_split, process, run_records
from ridsafe.tools.run.scenario import ScenarioFile

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
        self.sim.finish(self.t_s)


def lockstep_signing(loaded: ScenarioFile) -> codec.SigningConfig | None:
    """A key derived from the seed (a lockstep run must be bit-reproducible; it never leaves
    the process) and a fixed first timestamp."""
    if not loaded.run.sign_gcs_links:
        return None
    key = hashlib.sha256(f"ridsafe-lockstep-{loaded.scenario.seed}".encode()).digest()
    return codec.SigningConfig(key, codec.signing_timestamp_from_unix(loaded.scenario.start_unix_s))


def lockstep_autopilot_signing(loaded: ScenarioFile) -> codec.SigningConfig | None:
    """The companion <-> autopilot links' signing when ``run.sign_autopilot_links``: a key of
    its own, derived from the seed like the GCS links'."""
    if not loaded.run.sign_autopilot_links:
        return None
    key = hashlib.sha256(f"ridsafe-lockstep-autopilot-{loaded.scenario.seed}".encode()).digest()
    return codec.SigningConfig(key, codec.signing_timestamp_from_unix(loaded.scenario.start_unix_s))


def build(loaded: ScenarioFile, planner: str, sink: LogSink) -> Lockstep:
    """The scenario's cores, built by the factory (``run.cores``), connected for lockstep."""
    signing = lockstep_signing(loaded)
    autopilot_signing = lockstep_autopilot_signing(loaded)
    sim = cores.make_sim_backend(loaded, sink, cores.LOCKSTEP_SIM_ENDPOINTS, autopilot_signing)
    ids = cores.companion_ids(loaded)
    companions = cores.make_companions(loaded, ids, planner, sink, signing, autopilot_signing)
    gcs = cores.make_gcs(loaded, sink, signing)
    return connect(sim, companions, gcs, loaded.run.lockstep_tick_s)


def connect(sim: SimBackend, companions: dict[int, Companion], gcs: Gcs, tick_s: float) -> Lockstep:
    """Wire built cores: each companion to its vehicle's companion port and to the GCS."""
    by_name: dict[str, SansIoCore] = {SIM: sim, GCS: gcs}
    wires = []
    for sysid, companion in companions.items():
        by_name[companion_core(sysid)] = companion
        autopilot_port = (SIM, endpoint_name(sysid, EndpointKind.COMPANION))
        wires.append(Wire(autopilot_port, (companion_core(sysid), "autopilot")))
        gcs_port = (GCS, peer_endpoint(lockstep_peer(sysid)))
        wires.append(Wire(gcs_port, (companion_core(sysid), "gcs")))
    order = [SIM, *(companion_core(sysid) for sysid in companions), GCS]
    router = ByteRouter(by_name, wires, order)
    return Lockstep(sim, companions, gcs, router, tick_s)


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
    #: A split run: where each process's ticks went (``lockstep_split.PhaseTimes``), by
    #: process ("run", "worker"), then phase; None for a run on one process.
    phase_times_s: dict[str, dict[str, float]] | None = None
    #: A split run: this process's phases by the tick's place in its second
    #: (``PhaseTimes.by_tick``); None for a run on one process.
    phase_times_by_tick_s: dict[str, dict[int, float]] | None = None


def run_lockstep(
    loaded: ScenarioFile,
    planner: str,
    log_path: Path,
    on_progress: Callable[[float], None] | None = None,
    recorder_process: bool = True,
    live: LogSink | None = None,
    split: bool | None = None,
) -> RunResult:
    """Fly the scenario for its duration, logging to ``log_path``; Ctrl-C ends it early
    with a valid log. ``recorder_process``: write the log from a child process (on the other
    core; the same file), else from this one (a sweep's workers already use every core).
    ``live``: a second sink that sees every record too (the live Foxglove view). ``split``:
    step half the cores on a forked worker that also writes the log (``lockstep_split``; the
    same log, record for record); by default where the log may have a process of its own, the
    run has no live view and two CPUs are this process's."""
    if split is None:
        split = recorder_process and live is None and lockstep_split.can_split()
    if split:
        if live is not None:
            raise ValueError("a split lockstep run has no live view: split=False")
        return _run_split(loaded, planner, log_path, on_progress)
    wall_start = time.perf_counter()
    foxglove = loaded.run.foxglove_channels
    origin = loaded.scenario.origin
    log = process.open_run_log(log_path, origin, foxglove, child_process=recorder_process)
    with log as written:
        recorder = written if live is None else TeeSink((written, live))
        run_records.log_meta(recorder, run_records.run_meta(loaded, "lockstep", planner))
        build_start = time.perf_counter()
        try:
            run = build(loaded, planner, recorder)
        except KeyboardInterrupt:  # while compiling or loading the kernels: nothing flew
            return _not_started(recorder, log_path, wall_start)
        build_s = time.perf_counter() - build_start
        freeze_startup_objects()
        try:
            status, reason = _fly(run, loaded.scenario.duration_s, on_progress)
        finally:
            gc.unfreeze()
        run.finish()
        wall = time.perf_counter() - wall_start
        recorder.log(topics.RUN_END, run.t_s, run_records.run_end(wall, run.t_s, status, reason))
    return RunResult(status, reason, wall, run.t_s, log_path, build_s)


def _run_split(
    loaded: ScenarioFile,
    planner: str,
    log_path: Path,
    on_progress: Callable[[float], None] | None,
) -> RunResult:
    """``run_lockstep`` on two processes, the worker writing the log."""
    wall_start = time.perf_counter()
    buffer = lockstep_split.LaneBuffer()
    run_records.log_meta(buffer, run_records.run_meta(loaded, "lockstep", planner))
    build_start = time.perf_counter()
    origin, foxglove = loaded.scenario.origin, loaded.run.foxglove_channels
    try:
        serial = build(loaded, planner, buffer)
    except KeyboardInterrupt:
        with process.open_run_log(log_path, origin, foxglove) as log:
            for _, blob in buffer.take():  # the meta and what the cores logged while built
                lockstep_split.log_pickled(blob, log)
            return _not_started(log, log_path, wall_start)
    build_s = time.perf_counter() - build_start
    roles = lockstep_split.Roles(SIM, GCS, tuple(map(companion_core, serial.companions)))
    open_log = functools.partial(process.open_run_log, log_path, origin, foxglove)
    freeze_startup_objects()  # before the fork: the worker inherits them frozen
    try:
        with lockstep_split.SplitLockstep(
            serial.router, roles, serial.tick_s, buffer, open_log
        ) as run:
            status, reason = _fly(run, loaded.scenario.duration_s, on_progress)
            run.finish()
            wall = time.perf_counter() - wall_start
            end = run_records.run_end(wall, run.t_s, status, reason)
            buffer.log(topics.RUN_END, run.t_s, end)
            run.close()
    finally:
        gc.unfreeze()
    phases = {"run": run.times.seconds, "worker": run.worker_times.seconds}
    return RunResult(status, reason, wall, run.t_s, log_path, build_s, phases, run.times.by_tick)


def _fly(
    run: Lockstep | lockstep_split.SplitLockstep,
    duration_s: float,
    on_progress: Callable[[float], None] | None,
) -> tuple[str, str]:
    """Step ``run`` to ``duration_s``, or until Ctrl-C; returns (status, reason).

    The caller freezes what exists before (``freeze_startup_objects``: modules, kernels, the
    cores live for the whole flight; out of the collector's reach, a full collection walks
    only what the flight made: at 64 aircraft 39 of them took 101 ms each, 8 % of the run)
    and gives it back after (``gc.unfreeze``), so a sweep worker's next run can collect this
    one's cycles."""
    try:
        while run.t_s < duration_s - 1e-9:
            now_s = run.step()
            if on_progress is not None:
                on_progress(now_s)
    except KeyboardInterrupt:
        return "interrupted", "Ctrl-C"
    return "completed", ""


def _not_started(log: LogSink, log_path: Path, wall_start: float) -> RunResult:
    """The result (and the log's last record) of a run stopped while its cores were built."""
    wall = time.perf_counter() - wall_start
    reason = "Ctrl-C before the run started"
    log.log(topics.RUN_END, 0.0, run_records.run_end(wall, 0.0, "interrupted", reason))
    return RunResult("interrupted", reason, wall, 0.0, log_path, wall)
