"""MAVProxy 1.8.75 against ``ridsafe sim`` over real UDP, driven through its console as a
person would type (stdin, one command at a time); the sim's truth is the oracle."""

from __future__ import annotations

import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from tests.sim_backend.udp_sim import height_m, north_east_m, sim_on_udp

GCS_BASE = 26650
COMPANION_BASE = 27860
MAVPROXY = shutil.which("mavproxy.py", path=str(Path(sys.executable).parent))
MODULES = "mode,wp,param,fence,rally,cmdlong,arm,misc"


class Console:
    """A MAVProxy process; ``lines`` collects everything it prints."""

    def __init__(self, cwd: Path, port: int = GCS_BASE, modules: str = MODULES) -> None:
        assert MAVPROXY is not None
        self.proc = subprocess.Popen(
            [sys.executable, MAVPROXY, "--master", f"udpin:127.0.0.1:{port}", "--nowait",
             "--default-modules", modules],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
            cwd=cwd,
        )  # fmt: skip
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line.rstrip())

    def send(self, command: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(command + "\n")
        self.proc.stdin.flush()

    def wait_for(self, predicate: Callable[[], bool], timeout_s: float, what: str) -> None:
        deadline = time.monotonic() + timeout_s
        while not predicate():
            if time.monotonic() > deadline:
                tail = "\n".join(self.lines[-30:])
                raise AssertionError(f"timed out waiting for {what}; MAVProxy said:\n{tail}")
            time.sleep(0.1)

    def said(self, text: str) -> bool:
        return any(text in line for line in self.lines)

    def close(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()


@pytest.mark.udp
@pytest.mark.slow
@pytest.mark.skipif(MAVPROXY is None, reason="MAVProxy is a [test] extra")
def test_mavproxy_params_missions_guided_position_takeoff_and_land(tmp_path: Path) -> None:
    with sim_on_udp(GCS_BASE, COMPANION_BASE, speed=2.0) as backend:
        console = Console(tmp_path)
        try:
            console.wait_for(lambda: console.said("online system 1"), 20.0, "the vehicle")
            console.send("param fetch")
            console.wait_for(lambda: console.said("Saved 37 parameters"), 20.0, "param fetch")
            console.send("wp list")
            console.wait_for(lambda: console.said("Saved 1 waypoints"), 10.0, "wp list (home)")
            for kind in ("fence", "rally"):
                console.send(f"{kind} list")
                console.wait_for(lambda k=kind: console.said(f"Requesting 0 {k} items"),  # type: ignore[misc]
                                 10.0, f"{kind} list")  # fmt: skip
            console.send("mode GUIDED")
            console.send("arm throttle")
            console.wait_for(lambda: bool(backend.truth().armed[0]), 10.0, "arm throttle")
            console.send("takeoff 10")
            console.wait_for(lambda: height_m(backend) > 9.0, 30.0, "takeoff 10")

            home = backend.homes[0].home_geodetic
            north_deg = 40.0 / 111_000.0  # 40 m north, 15 m up
            console.send(f"guided {home.lat_deg + north_deg:.7f} {home.lon_deg:.7f} 15")
            console.wait_for(lambda: console.said("DO_REPOSITION: ACCEPTED"), 5.0, "guided ACK")
            console.wait_for(lambda: north_east_m(backend)[0] > 38.0 and height_m(backend) > 14.0,
                             30.0, "guided LAT LON ALT")  # fmt: skip
            time.sleep(2.0)
            north_before = north_east_m(backend)[0]
            console.send("position 10 0 0")  # MAV_FRAME_BODY_NED: 10 m ahead (north)
            console.wait_for(lambda: north_east_m(backend)[0] > north_before + 9.0, 20.0,
                             "position 10 0 0")  # fmt: skip
            console.send("mode LAND")
            console.wait_for(lambda: not backend.truth().armed[0], 90.0, "LAND and disarm")
            assert height_m(backend) < 0.3
            assert not console.said("fence breach")
        finally:
            console.close()
