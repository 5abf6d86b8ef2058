"""A supervisor that stops an app during its start-up (here: waiting for a start instant a
minute away, as the apps of a live run do) gets a clean exit and a finished log, not a
process killed with its log open."""

from __future__ import annotations

import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from ridsafe.tools.runlog.reader import read_records

ROOT = Path(__file__).resolve().parents[3]
_CLI = """
import argparse, sys
from ridsafe.tools.cli import {module}
parser = argparse.ArgumentParser()
{module}.register(parser.add_subparsers())
args = parser.parse_args(sys.argv[1:])
sys.exit(args.func(args))
"""


@pytest.mark.udp
@pytest.mark.parametrize(
    ("module", "argv"),
    [
        ("gcs_cmd", ["gcs", "--listen", "udpin:127.0.0.1:0", "--clock", "local"]),
        ("sim_cmd", ["sim", "--vehicles", "1"]),
        (
            "companion_cmd",
            [
                "companion",
                "--vehicle",
                "1",
                "--autopilot",
                "udpin:127.0.0.1:0",
                "--gcs",
                "udpout:127.0.0.1:9",
            ],
        ),
    ],
    ids=["gcs", "sim", "companion"],
)
def test_sigterm_while_waiting_for_the_start_closes_the_log(
    tmp_path: Path, module: str, argv: list[str]
) -> None:
    log = tmp_path / "app.mcap"
    t0 = f"{time.time() + 60.0:.3f}"
    proc = subprocess.Popen(
        [sys.executable, "-c", _CLI.format(module=module), *argv, "--t0-unix", t0,
         "--log", str(log)],
        cwd=ROOT, stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert proc.stdout is not None
        ready, _, _ = select.select([proc.stdout], [], [], 30.0)
        assert ready and proc.stdout.readline()  # its first line: it is up
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=20) == 0
    finally:
        proc.kill()
        proc.wait()
    assert list(read_records(log))  # a finished MCAP file, read back
