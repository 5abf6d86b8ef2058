"""``examples/fly_guided.py`` unchanged against a real ArduCopter SITL from a cold boot (its
twin against ``ridsafe sim`` is tests/sim_backend/test_sim_udp.py)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.sitl import ROOT, arducopter, require_sitl

GCS_PORT, COMPANION_PORT, INSTANCE = 46850, 46860, 9


@pytest.mark.slow
@pytest.mark.udp
@pytest.mark.skip(
    reason="open defect (issue 17): from a cold boot at --speedup 4 the SITL refused arming with "
    "'Arm: Gyros inconsistent' for over 100 s on the 2-core machine, so the example timed out"
)
def test_fly_guided_example_flies_arducopter_sitl_unchanged(tmp_path: Path) -> None:
    require_sitl()
    with arducopter(tmp_path / "sitl", (36.1412754, -86.806922, 180.0), GCS_PORT,
                    COMPANION_PORT, INSTANCE, speedup=4.0):  # fmt: skip
        script = subprocess.run(
            [sys.executable, "examples/fly_guided.py", "--base-port", str(GCS_PORT),
             "--north", "60", "--east", "-40", "--alt", "25"],
            cwd=ROOT, capture_output=True, text=True, timeout=240, check=False,
        )  # fmt: skip
    out = script.stdout + script.stderr
    assert script.returncode == 0, out
    assert "heartbeat from system 1" in out
    assert "arming refused" in out  # the cold boot's pre-arm period, waited out
    assert "target reached; landing" in out
    assert "landed and disarmed" in out
