"""Live runs: sim backend, GCS and companions as separate processes over MAVLink/UDP.

The orchestrator starts ``ridsafe sim``, ``ridsafe gcs`` and ``ridsafe companion`` as child
processes with the effective scenario file, a common start instant (``--t0-unix``, so every
process's sim clock reads 0 at the same wall instant) and a part log each
(``OUT/parts/<name>.mcap``); shows progress; and, when the children are done, merges the
parts into ``OUT/run.mcap``. Ctrl-C stops every child cleanly (each closes its log); a child
that dies stops the run with its name, exit code and last log lines instead of a hang.
Children's stdout/stderr go to ``OUT/logs/<name>.log``.
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

logger = logging.getLogger(__name__)

STARTUP_MARGIN_S = 4.0  # wall time for the children to import and open their sockets
STOP_GRACE_S = 10.0


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
    """SIGINT (children close their logs), then SIGTERM, then SIGKILL."""
    for sig, grace in ((signal.SIGINT, STOP_GRACE_S), (signal.SIGTERM, 5.0)):
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
