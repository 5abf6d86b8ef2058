"""A real ArduCopter SITL for tests, started from a cold boot (no eeprom), or a skip.

The build lives outside the repository (ArduPilot is GPLv3; see ``../shared/sitl/README.md``):
``$RIDSAFE_SITL_DIR`` or ``shared/sitl`` in a folder above the repository (``../shared/sitl``
for a clone, ``../../shared/sitl`` for a worktree under ``wt/``), holding
``arducopter.xz`` and ``copter.parm``. It is unpacked into the test's temporary folder.
"""

from __future__ import annotations

import lzma
import os
import shutil
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

os.environ.setdefault("MAVLINK20", "1")

ROOT = Path(__file__).resolve().parents[1]
SITL_ENV = "RIDSAFE_SITL_DIR"


def sitl_dir() -> Path | None:
    """Where the SITL build is, or None."""
    named = os.environ.get(SITL_ENV)
    candidates = [Path(named)] if named else []
    candidates += [above / "shared" / "sitl" for above in ROOT.parents]
    for folder in candidates:
        if (folder / "arducopter.xz").is_file() and (folder / "copter.parm").is_file():
            return folder
    return None


def require_sitl() -> Path:
    folder = sitl_dir()
    if folder is None:
        pytest.skip(
            f"no ArduCopter SITL: set {SITL_ENV} or put arducopter.xz and copter.parm in "
            f"{ROOT.parent / 'shared' / 'sitl'}"
        )
    return folder


@contextmanager
def arducopter(
    workdir: Path,
    home: tuple[float, float, float],
    gcs_port: int,
    companion_port: int,
    instance: int,
    speedup: float = 1.0,
) -> Iterator[subprocess.Popen[bytes]]:
    """ArduCopter SITL booting now: serial0 -> udp ``gcs_port``, serial1 -> ``companion_port``
    (both ``udpclient``: it sends to 127.0.0.1 there; a client listens with ``udpin``)."""
    folder = require_sitl()
    workdir.mkdir(parents=True, exist_ok=True)
    binary = workdir / "arducopter"
    if not binary.exists():
        with lzma.open(folder / "arducopter.xz") as packed, binary.open("wb") as out:
            shutil.copyfileobj(packed, out)
        binary.chmod(0o755)
    shutil.copy(folder / "copter.parm", workdir / "copter.parm")
    lat, lon, alt = home
    proc = subprocess.Popen(
        [str(binary), "--model", "+", "--speedup", f"{speedup:g}", f"-I{instance}",
         "--defaults", "copter.parm", "--home", f"{lat:.7f},{lon:.7f},{alt:.2f},0",
         "--serial0", f"udpclient:127.0.0.1:{gcs_port}",
         "--serial1", f"udpclient:127.0.0.1:{companion_port}"],
        cwd=workdir, stdout=(workdir / "sitl.log").open("wb"), stderr=subprocess.STDOUT,
    )  # fmt: skip
    try:
        yield proc
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
