"""``ridsafe sim`` (the same builder the command uses) on real UDP sockets, in a thread, so a
test can drive it with a client nobody here wrote and read the sim's truth as the oracle."""

from __future__ import annotations

import argparse
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager

from ridsafe.common.logsink import NullSink
from ridsafe.common.runner import UdpRunner
from ridsafe.sim_backend.app import open_endpoints
from ridsafe.sim_backend.world import SimBackend
from ridsafe.tools.cli import app_args, sim_cmd


@contextmanager
def sim_on_udp(
    gcs_base: int, companion_base: int, speed: float = 1.0, sets: Sequence[str] = ()
) -> Iterator[SimBackend]:
    """One benign vehicle, no spoofer; vehicle 1 streams to 127.0.0.1:``gcs_base``."""
    parser = argparse.ArgumentParser()
    sim_cmd.register(parser.add_subparsers())
    argv = ["sim", "--vehicles", "1", "--no-spoofer", "--speed", str(speed),
            "--set", f"sim.ports.gcs_out_base={gcs_base}",
            "--set", f"sim.ports.companion_base={companion_base}"]  # fmt: skip
    for item in sets:
        argv += ["--set", item]
    args = parser.parse_args(argv)
    loaded = sim_cmd.load_from_args(args)
    backend = sim_cmd.build_backend(loaded, NullSink())
    endpoints = open_endpoints(backend, loaded.sim.ports)
    runner = UdpRunner(backend, endpoints, app_args.make_clock(args), loaded.run.live_tick_s)
    thread = threading.Thread(target=runner.run, kwargs={"until_s": 3600.0}, daemon=True)
    thread.start()
    try:
        yield backend
    finally:
        runner.stop()
        thread.join(timeout=10.0)
        runner.close()


def height_m(backend: SimBackend, sysid: int = 1) -> float:
    """Vehicle ``sysid``'s height above its home (m), from the sim's truth."""
    home = backend.homes[sysid - 1]
    return float(-home.enu_to_local_ned(backend.truth().p_enu_m[sysid - 1])[2])


def north_east_m(backend: SimBackend, sysid: int = 1) -> tuple[float, float]:
    home = backend.homes[sysid - 1]
    p = home.enu_to_local_ned(backend.truth().p_enu_m[sysid - 1])
    return float(p[0]), float(p[1])
