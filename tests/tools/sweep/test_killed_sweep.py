"""A sweep killed outright (SIGKILL: no cleanup runs) leaves no pool worker behind: each
worker notices its parent is gone and exits, instead of waiting forever on a queue nobody
writes (as ``ProcessPoolExecutor`` workers do)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from ridsafe.tools.run.scenario import REPO_ROOT
from ridsafe.tools.sweep.engines import PARENT_POLL_S

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")


def _live_stat(pid: int) -> list[str]:
    """/proc/PID/stat after the command name (state, ppid, ...); [] once the process is gone
    or a zombie."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return []
    return stat if stat and stat[0] != "Z" else []


def _alive(pid: int) -> bool:
    return bool(_live_stat(pid))


def _children(pid: int) -> list[int]:
    """Live processes whose parent is ``pid``."""
    pids = (int(p.name) for p in Path("/proc").iterdir() if p.name.isdigit())
    return [p for p, stat in ((p, _live_stat(p)) for p in pids) if stat and int(stat[1]) == pid]


def test_workers_of_a_killed_sweep_exit(tmp_path: Path) -> None:
    argv = [
        sys.executable,
        "-m",
        "ridsafe.tools.cli",
        "sweep",
        str(REPO_ROOT / "configs/paper.yaml"),
    ]
    argv += ["--densities", "8", "--seeds", "0:20", "--planners", "aware", "--workers", "2"]
    argv += ["--out", str(tmp_path / "sweep"), "--no-progress"]
    sweep = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60.0
        workers: list[int] = []
        while len(workers) < 2 and time.monotonic() < deadline:  # the pool's processes
            time.sleep(0.2)
            workers = [p for p in _children(sweep.pid) if b"spawn_main" in _cmdline(p)]
        assert len(workers) == 2, "the sweep never started its workers"
        time.sleep(2.0)  # into their first runs
    finally:
        os.kill(sweep.pid, signal.SIGKILL)
        sweep.wait()
    deadline = time.monotonic() + 5 * PARENT_POLL_S + 5.0
    while any(_alive(p) for p in workers) and time.monotonic() < deadline:
        time.sleep(0.2)
    left = [p for p in workers if _alive(p)]
    for pid in left:  # do not leak them into the rest of the suite
        os.kill(pid, signal.SIGKILL)
    assert not left, f"workers {left} outlived their sweep"


def _cmdline(pid: int) -> bytes:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return b""
