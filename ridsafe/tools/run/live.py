"""Live runs: sim backend, GCS and companions as separate processes over MAVLink/UDP.

:func:`run_live` compiles the kernels once (``lockstep.warm_up``), then starts ``ridsafe sim``,
``ridsafe gcs`` and ``ridsafe companion`` (:data:`COMPANIONS_PER_PROCESS` aircraft per
process) as child processes (:func:`children`) with the effective scenario file, a common
start instant (``--t0-unix``, so every process's sim clock reads 0 at the same wall instant)
and a part log each (``OUT/parts/<name>.mcap``); logs ``/run/meta`` and ``/run/end`` in a part
of its own; and, when the children are done, merges the parts into ``OUT/run.mcap``. Each
child builds its cores with the same factory as a lockstep run (``run.cores``). Ctrl-C stops
every child cleanly (each closes its log); a child that dies stops the run with its name, exit
code and last log lines instead of a hang. Children's stdout/stderr go to
``OUT/logs/<name>.log``.
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from ridsafe.common import topics
from ridsafe.common.udp import parse_connection_string
from ridsafe.tools.run import cores, process, run_records
from ridsafe.tools.run.lockstep import warm_up
from ridsafe.tools.run.scenario import ScenarioFile

logger = logging.getLogger(__name__)

STARTUP_MARGIN_S = 4.0  # wall time for the children to import and open their sockets
STOP_GRACE_S = 10.0
COMPANIONS_PER_PROCESS = 8


@dataclass
class Child:
    name: str
    argv: list[str]
    log_path: Path
    process: subprocess.Popen[bytes] | None = None

    def start(self) -> None:
        self.log_path.parent.mkdir(parents=True, exist_ok=True)
        with self.log_path.open("wb") as log:
            self.process = subprocess.Popen(
                self.argv, stdout=log, stderr=subprocess.STDOUT, start_new_session=True
            )

    @property
    def returncode(self) -> int | None:
        return None if self.process is None else self.process.poll()

    def signal(self, sig: int) -> None:
        if self.process is not None and self.process.poll() is None:
            with contextlib.suppress(ProcessLookupError):  # exited in between
                os.killpg(self.process.pid, sig)

    def tail(self, lines: int = 12) -> str:
        try:
            text = self.log_path.read_text(errors="replace")
        except OSError:
            return ""
        return "\n".join(text.splitlines()[-lines:])


@dataclass
class LiveOutcome:
    status: str  # 'completed', 'interrupted' or 'failed'
    reason: str
    wall_clock_s: float
    parts: list[Path] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)  # for people: what the merge found


def cli_argv(*args: str) -> list[str]:
    """argv running ``ridsafe ARGS`` with this interpreter (works without the console script)."""
    return [sys.executable, "-m", "ridsafe.tools.cli", *args]


def supervise(
    children: Sequence[Child],
    duration_s: float,
    speed: float,
    t0_unix: float,
    on_progress: Callable[[float], None] | None = None,
) -> LiveOutcome:
    """Start ``children``, wait until they finish or one fails or Ctrl-C; stop the rest."""
    wall_start = time.monotonic()
    for child in children:
        child.start()
    status, reason = "completed", ""
    try:
        while True:
            failed = [c for c in children if c.returncode not in (None, 0)]
            if failed:
                child = failed[0]
                status = "failed"
                reason = (
                    f"{child.name} exited with code {child.returncode}; its log "
                    f"({child.log_path}) ends with:\n{child.tail()}"
                )
                break
            if all(c.returncode == 0 for c in children):
                break
            if on_progress is not None:
                on_progress(max(0.0, (time.time() - t0_unix) * speed))
            if (time.time() - t0_unix) * speed > duration_s + 30.0 * speed:
                status, reason = "failed", "children did not finish after the run's duration"
                break
            time.sleep(0.2)
    except KeyboardInterrupt:
        status, reason = "interrupted", "Ctrl-C"
    stop(children)
    return LiveOutcome(status, reason, time.monotonic() - wall_start)


def stop(children: Sequence[Child]) -> None:
    """SIGINT (children close their logs), then SIGTERM, then SIGKILL. Where this process
    ignores SIGINT (a shell's background job), its children inherited that and would sit out
    the SIGINT's grace: they get SIGTERM first (which closes their logs too)."""
    steps = [(signal.SIGINT, STOP_GRACE_S), (signal.SIGTERM, 5.0)]
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        steps = steps[1:]
    for sig, grace in steps:
        running = [c for c in children if c.returncode is None]
        if not running:
            return
        for child in running:
            child.signal(sig)
        deadline = time.monotonic() + grace
        while time.monotonic() < deadline and any(c.returncode is None for c in running):
            time.sleep(0.05)
    for child in children:
        if child.returncode is None:
            logger.warning("%s did not stop; killing it", child.name)
            child.signal(signal.SIGKILL)


def children(
    loaded: ScenarioFile,
    planner: str,
    out: Path,
    scenario_path: Path,
    speed: float,
    t0: float,
    live_view: str | None = None,
) -> list[Child]:
    """What a live run starts: the sim, the GCS and the companions in groups, each with the
    effective scenario file, the start instant and a part log (and a fresh signing key for
    the GCS links when ``run.sign_gcs_links``, written to ``OUT/mavlink.key``, and one for
    the companion <-> autopilot links when ``run.sign_autopilot_links``, in
    ``OUT/autopilot.key``); the sim serves the live Foxglove view on ``live_view``
    ([HOST:]PORT) if given."""
    duration = loaded.scenario.duration_s
    common = [str(scenario_path), "--speed", repr(speed), "--duration", repr(duration)]
    common += ["--t0-unix", repr(t0)]
    signing: list[str] = []
    if loaded.run.sign_gcs_links:
        key = out / "mavlink.key"
        key.write_text(os.urandom(32).hex())
        key.chmod(0o600)
        signing = ["--signing-key", str(key)]
    autopilot_signing: list[str] = []
    if loaded.run.sign_autopilot_links:
        key = out / "autopilot.key"
        key.write_text(os.urandom(32).hex())
        key.chmod(0o600)
        autopilot_signing = ["--autopilot-signing-key", str(key)]
    listen = parse_connection_string(loaded.run.gcs_listen)
    gcs_out = loaded.run.gcs_connect or f"udpout:{listen.host}:{listen.port}"
    parts, logs = out / "parts", out / "logs"
    started = [
        Child("sim", cli_argv("sim", *common, *autopilot_signing,
                              "--log", str(parts / "sim.mcap"),
                              *(("--foxglove", live_view) if live_view else ())),
              logs / "sim.log"),
        Child("gcs", cli_argv("gcs", *common, "--listen", loaded.run.gcs_listen,
                              *signing, "--log", str(parts / "gcs.mcap")),
              logs / "gcs.log"),
    ]  # fmt: skip
    ids = list(cores.companion_ids(loaded))
    for first in range(0, len(ids), COMPANIONS_PER_PROCESS):
        group = ids[first : first + COMPANIONS_PER_PROCESS]
        name = f"companions-{group[0]}-{group[-1]}"
        argv = cli_argv(
            "companion", *common, "--vehicle", f"{group[0]}-{group[-1]}", "--gcs", gcs_out,
            "--planner", planner, *signing, *autopilot_signing,
            "--log", str(parts / f"{name}.mcap"),
            "--keep-running",  # landed aircraft keep broadcasting until the run ends
        )  # fmt: skip
        started.append(Child(name, argv, logs / f"{name}.log"))
    return started


def run_live(
    loaded: ScenarioFile,
    planner: str,
    out: Path,
    scenario_path: Path,
    speed: float,
    on_progress: Callable[[float], None] | None = None,
    on_warm: Callable[[float], None] | None = None,
    live_view: str | None = None,
) -> LiveOutcome:
    """Fly the scenario live into ``out`` (see the module docstring); ``on_warm`` hears how
    long compiling the kernels took, ``on_progress`` the sim time now and then."""
    from ridsafe.tools.runlog.merge import merge_parts  # noqa: PLC0415 (mcap only here)

    duration = loaded.scenario.duration_s
    parts = out / "parts"
    warm_s = warm_up(loaded, planner)
    if on_warm is not None:
        on_warm(warm_s)
    t0 = time.time() + STARTUP_MARGIN_S
    started = children(loaded, planner, out, scenario_path, speed, t0, live_view)
    own = parts / "run.mcap"
    foxglove = loaded.run.foxglove_channels
    with process.open_run_log(own, loaded.scenario.origin, foxglove) as recorder:
        run_records.log_meta(recorder, run_records.run_meta(loaded, "live", planner))
        outcome = supervise(started, duration, speed, t0, on_progress)
        end_s = min(duration, max(0.0, (time.time() - t0) * speed))
        end = run_records.run_end(outcome.wall_clock_s, end_s, outcome.status, outcome.reason)
        recorder.log(topics.RUN_END, end_s, end)
    report = merge_parts(sorted(parts.glob("*.mcap")), out / "run.mcap")
    outcome.parts = [part.path for part in report.parts]
    outcome.notes = [
        f"{part.path.name} was cut off ({part.error}); kept its {part.messages} readable messages"
        for part in report.parts
        if not part.complete
    ]
    return outcome
