"""A plain pymavlink script flies sim vehicle 2 over real UDP, as a ground station would."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
GCS_BASE = 24550  # away from a real SITL's 14550
COMPANION_BASE = 25760


@pytest.mark.udp
def test_pymavlink_script_flies_vehicle_2_in_guided_over_udp() -> None:
    sim = subprocess.Popen(
        [
            sys.executable, "-m", "ridsafe.tools.cli", "sim", "--vehicles", "2", "--no-spoofer",
            "--speed", "8", "--duration", "400",
            "--set", f"sim.ports.gcs_out_base={GCS_BASE}",
            "--set", f"sim.ports.companion_base={COMPANION_BASE}",
        ],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    try:
        time.sleep(0.5)
        script = subprocess.run(
            [
                sys.executable, "examples/fly_guided.py", "--vehicle", "2",
                "--base-port", str(GCS_BASE), "--north", "60", "--east", "-40", "--alt", "25",
            ],
            cwd=ROOT, capture_output=True, text=True, timeout=120, check=False,
        )  # fmt: skip
    finally:
        sim.terminate()
        sim_output, _ = sim.communicate(timeout=10)
    assert script.returncode == 0, script.stdout + script.stderr + sim_output
    assert "heartbeat from system 2" in script.stdout
    assert "target reached; landing" in script.stdout
    assert "landed and disarmed" in script.stdout
    assert "vehicle 2 (RSAF800000002)" in sim_output
