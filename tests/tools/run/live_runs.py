"""Start a live ``ridsafe run`` (sim, GCS and companions as processes) for the live tests."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from tests.signals import keyboard_interrupt_on_sigint

ROOT = Path(__file__).resolve().parents[3]


def start_live_run(out: Path, *args: str) -> subprocess.Popen[str]:
    """``ridsafe run --mode live --out OUT --planner straight-line ARGS...`` from the repository
    root, its output (stdout and stderr) on one text pipe; Ctrl-C (SIGINT) reaches it however
    pytest was started."""
    argv = [sys.executable, "-m", "ridsafe.tools.cli", "run", "--mode", "live", "--out", str(out)]
    with keyboard_interrupt_on_sigint():
        return subprocess.Popen(
            [*argv, "--planner", "straight-line", *args],
            cwd=ROOT,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
