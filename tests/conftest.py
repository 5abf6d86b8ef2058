"""Test session settings: single-threaded BLAS, as every ridsafe process runs (see cli.py),
and no time limit on a hypothesis example: speed is measured in ``bench/``, and a first
example that loads a compiled kernel from numba's cache (0.1-0.4 s) or a loaded CI host
would otherwise fail a property test for its clock, not its property.

Where numba's or mypy's on-disk cache is missing (a clean clone), the session starts
``tests/warm_caches.py`` at the lowest priority to fill it on the core the session leaves
idle, and stops it when the session ends."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import settings

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

settings.register_profile("ridsafe", deadline=None)
settings.load_profile("ridsafe")

ROOT = Path(__file__).resolve().parents[1]
_warming: list[subprocess.Popen[bytes]] = []


def _cold_caches() -> list[str]:
    """The caches ``tests/warm_caches.py`` fills that hold nothing yet."""
    cold = []
    if next(ROOT.glob("ridsafe/**/__pycache__/*.nbi"), None) is None:
        cold.append("numba")
    if not (ROOT / ".mypy_cache").is_dir():
        cold.append("mypy")
    return cold


def pytest_sessionstart(session: pytest.Session) -> None:
    if cold := _cold_caches():
        _warming.append(
            subprocess.Popen(
                [sys.executable, "-m", "tests.warm_caches", *cold],
                cwd=ROOT,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                start_new_session=True,  # its mypy child is stopped with it
            )
        )


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    for proc in _warming:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGTERM)
        proc.wait()
