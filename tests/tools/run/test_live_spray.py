"""Issue 14's live Done-when, over real UDP: three undisturbed live runs of one seed, then the
same run while a hostile local process sends 50,000 garbage and mutated datagrams (CRC
recomputed, built from a lockstep run's datagrams) at each app's ports (the sim's, the
GCS's, the companions' own sockets) and the one-datagram cases of the issue (a NaN
DO_SET_MODE, SYSTEM_TIME 2^64-1 and a "disarmed" HEARTBEAT from the autopilot's ids), and a
relay on the companions' way to the GCS forwards their traffic and replays it from a socket
of its own. The sprayed run must complete with every goal reached, the alert no later than
5 s (sim time, from when the spoofer was heard) after the latest undisturbed run's, no link
lost, no handler error, the replays refused, the companions served as many regions as
undisturbed, and its rejections counted in ``/app/counters``.

The alert is timed as ``detection_delay_s``, from when four aircraft had heard the spoofer:
an app that starts late under load shifts the whole flight in sim time (up to 16 s for the
third undisturbed run), and that is start-up, not detection. The spoofer lies by 212 m
(``SPOOFER_OFFSET_ENU_M``) instead of the default scenario's 71 m. At 71 m on the 1 dB
channel its MLAT statistic hovers just under the threshold for 10-15 s, so when it crosses
depends on the noise a live run happens to draw: seed 0's live alerts came 9-23 s
after the spoofer was heard, and a sprayed run failed the bar without the spray being
the cause (its GCS accepted 1588 of 1600 observations). A 212 m lie is caught at the first
fit (lockstep: 4.75 s on seeds 0-5; live: 4.2-6.2 s after it was heard, 8.9 s for a run that
started late), so a sprayed alert 5 s later than every undisturbed one is the spray's doing.
How the detectors fare on lies near their threshold is issue 15's question, measured by
``ridsafe sweep``, not here.

The runs go at ``SPEED`` times real time for ``DURATION_S`` (the last aircraft arrives at
about 70 s, 80 s when the machine is loaded), the three undisturbed ones side by side on
ports of their own: together they load the machine about as much as the sprayed run and its
sprayer (each is started once the previous one's apps are up: starting them is what costs
CPU, and an app that starts late flies late). The bar is the issue's, in sim seconds. A
killed companion's aircraft landing by itself is tested in
``tests/tools/run/test_companion_loss.py`` (whole run, lockstep) and
``tests/sim_backend/test_failsafe.py``; a replay that changes nothing the companion
receives, message for message, in ``tests/gcs/test_gcs_replay.py``.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import random
import re
import selectors
import socket
import subprocess
import threading
import time
from collections import deque
from pathlib import Path
from typing import Any

import pytest

from ridsafe.common import codec, topics
from ridsafe.common import messages as m
from ridsafe.common.dialect import ridsafe_v20 as mav
from ridsafe.common.udp import Address, UdpEndpoint
from ridsafe.tools.fuzz.harness import warm_up
from ridsafe.tools.fuzz.mutate import Mutator
from ridsafe.tools.run.scenario import load_scenario_file
from ridsafe.tools.runlog.reader import read_records
from tests.tools.run.live_runs import start_live_run

# Fixed ports below the kernel's ephemeral range (32768-60999 on Linux): a socket bound to
# port 0 anywhere on the host can never take one of them from a run (it did: "cannot bind
# 127.0.0.1:36760: Address already in use", twice in six suites). Apart from test_live's.
COMPANION_BASE, GCS_OUT_BASE, GCS_PORT = 30760, 30550, 30450
RELAY_PORT = 30460  # where the sprayed run's companions send to the GCS
CLEAN_PORT_OFFSETS = (400, 800, 1200)  # the undisturbed runs', side by side (up to 32000)
SIM_PORTS = [COMPANION_BASE + 10 * k for k in range(4)] + [GCS_OUT_BASE + 10 * k for k in range(4)]
SPEED, SEED, DURATION_S = 6.0, 0, 100.0
SPOOFER_OFFSET_ENU_M = "[150.0, 150.0, 0.0]"  # its lie: the module docstring says why
PER_APP = 50_000  # datagrams at each app's ports
BURST = 25  # datagrams per app between two 1 ms pauses
ALERT_SLACK_S = 5.0
REPLAY_EVERY = 5  # the relay re-sends every 5th datagram a companion sends to the GCS
REPLAY_DELAY_S = 0.5  # wall time after forwarding it
#: The relay captures datagrams to replay this long (wall time) after the first one it sees,
#: so that every replay reaches a GCS still running (the run lasts DURATION_S / SPEED).
CAPTURE_S = DURATION_S / SPEED - 2.0
DROPS = {  # the counters of what an app dropped or refused (links, shell, runner)
    *("bad_data", "truncated", "unknown_id", "invalid_value", "rejected_signature"),
    *("unknown_endpoint", "foreign_system", "other_component", "bad_sysid"),
    *("not_from_locked_peer", "not_from_remote"),
    "kernel_overflow",  # lost in a full receive buffer (a loaded machine): counted too
}
# The spray starts once the sim reports every aircraft airborne (the companions have locked
# their ports). Earlier, a sprayer that sends MAVLink with a companion's ids before the
# companion itself would be locked as the sim port's peer: without signing on that link
# nothing tells them apart (see common/peer_lock.py); with ``run.sign_autopilot_links`` it
# cannot (tests/common/test_autopilot_signing.py).


def _run(out: Path, port_offset: int = 0, relay: bool = False) -> subprocess.Popen[str]:
    ports = [
        "--set", f"sim.ports.companion_base={COMPANION_BASE + port_offset}",
        "--set", f"sim.ports.gcs_out_base={GCS_OUT_BASE + port_offset}",
        "--set", f"run.gcs_listen=udpin:127.0.0.1:{GCS_PORT + port_offset}",
    ]  # fmt: skip
    if relay:
        ports += ["--set", f"run.gcs_connect=udpout:127.0.0.1:{RELAY_PORT}"]
    flags = ["--seed", str(SEED), "--speed", str(SPEED), "--duration", str(DURATION_S)]
    flags += ["--set", f"scenario.spoofer.offset_enu_m={SPOOFER_OFFSET_ENU_M}"]
    return start_live_run(out, *flags, *ports)


STARTED = {"sim.log": "t=", "gcs.log": "running at", "companions-1-4.log": "companion 4:"}


def _wait_until_started(out: Path, timeout_s: float = 60.0) -> None:
    """Until every app of the live run in ``out`` has started (its log says so)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        logs = {name: out / "logs" / name for name in STARTED}
        if all(p.exists() and STARTED[n] in p.read_text(errors="replace") for n, p in logs.items()):
            return
        time.sleep(0.2)


def _finish(proc: subprocess.Popen[str], out: Path) -> dict[str, Any]:
    output, _ = proc.communicate(timeout=300)
    assert proc.returncode == 0, output
    summary: dict[str, Any] = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed", summary
    return summary["metrics"]  # type: ignore[no-any-return]


def _companion_ports(out: Path) -> list[int]:
    """The UDP ports the companions' process has bound (found through /proc)."""
    inodes: set[str] = set()
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            cmdline = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
            if "--vehicle" not in cmdline or str(out) not in cmdline:
                continue
            for fd in os.listdir(f"/proc/{pid}/fd"):
                found = re.match(r"socket:\[(\d+)\]", os.readlink(f"/proc/{pid}/fd/{fd}"))
                if found:
                    inodes.add(found.group(1))
        except OSError:  # a process that ended meanwhile
            continue
    ports = []
    for line in Path("/proc/net/udp").read_text().splitlines()[1:]:
        cols = line.split()
        if cols[9] in inodes:
            ports.append(int(cols[1].split(":")[1], 16))
    return ports


def _one_datagram_cases() -> list[tuple[str, bytes]]:
    """The issue's single datagrams: for the sim (a NaN mode from the companion's ids) and
    for a companion (from its autopilot's ids)."""
    companion = codec.MavlinkLink(1, 191)
    nan_mode = m.CommandLong(1, 1, int(m.MavCmd.DO_SET_MODE), 0, (math.nan, 4.0, 0, 0, 0, 0, 0))
    autopilot = mav.MAVLink(None, srcSystem=1, srcComponent=1)
    system_time = bytes(mav.MAVLink_system_time_message(2**64 - 1, 1000).pack(autopilot))
    disarmed = m.Heartbeat(
        int(m.MavType.OCTOROTOR),
        int(m.MavAutopilot.ARDUPILOTMEGA),
        int(m.MavModeFlag.CUSTOM_MODE_ENABLED),
        int(m.CopterMode.GUIDED),
        int(m.MavState.STANDBY),
    )
    return [
        ("sim", bytes(companion.pack(nan_mode))),
        ("companion", system_time),
        ("companion", bytes(codec.MavlinkLink(1, 1).pack(disarmed))),
    ]


class Sprayer:
    """The hostile process: per app, ``PER_APP`` datagrams, half random bytes, half mutated
    MAVLink; the one-datagram cases among them."""

    def __init__(self, out: Path, seeds: list[bytes]) -> None:
        self.out, self.seeds = out, seeds
        self.sent = {"sim": 0, "gcs": 0, "companion": 0}
        self.garbage = dict.fromkeys(self.sent, 0)  # random bytes: never genuine
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._spray, daemon=True)

    def _wait_until_flying(self) -> bool:
        sim_log = self.out / "logs" / "sim.log"
        while not self.stop.is_set():
            if sim_log.exists() and "airborne 5" in sim_log.read_text(errors="replace"):
                return True
            self.stop.wait(0.1)
        return False

    def _spray(self) -> None:
        if not self._wait_until_flying():
            return
        rng, companion_ports = random.Random(14), _companion_ports(self.out)
        mutator = Mutator(rng)
        targets = {"sim": SIM_PORTS, "gcs": [GCS_PORT], "companion": companion_ports}
        cases = _one_datagram_cases()
        with UdpEndpoint() as sock:
            bursts = 0
            while not self.stop.is_set() and min(self.sent.values()) < PER_APP:
                for app, ports in targets.items():
                    for _ in range(BURST):
                        if self.sent[app] >= PER_APP or not ports:
                            break
                        if rng.random() < 0.5:
                            data = rng.randbytes(rng.randint(1, 280))
                            self.garbage[app] += 1
                        else:
                            data = mutator.mutate(rng.choice(self.seeds), rng.choice(self.seeds))
                        sock.send(data, ("127.0.0.1", rng.choice(ports)))
                        self.sent[app] += 1
                if bursts % 20 == 0:
                    for app, data in cases:
                        for port in targets[app]:
                            sock.send(data, ("127.0.0.1", port))
                bursts += 1
                self.stop.wait(0.001)


class Relay:
    """A man in the middle on the companions' way to the GCS: forwards every datagram both
    ways, each companion through a socket of its own (so the GCS sees one peer per
    companion), and re-sends every ``REPLAY_EVERY``-th datagram a companion sent, once,
    ``REPLAY_DELAY_S`` later, from one more socket, as the issue's replaying relay did."""

    def __init__(self) -> None:
        self.listen = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.listen.bind(("127.0.0.1", RELAY_PORT))
        self.replayer = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.forward: dict[Address, socket.socket] = {}  # companion address -> its socket
        self.captured: deque[tuple[float, bytes]] = deque()
        self.forwarded = self.replayed = 0
        self.first_s: float | None = None  # when the first datagram came (monotonic)
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._relay, daemon=True)

    def _relay(self) -> None:
        with selectors.DefaultSelector() as selector:
            selector.register(self.listen, selectors.EVENT_READ, None)
            while not self.stop.is_set():
                for key, _ in selector.select(timeout=0.01):
                    if key.data is None:
                        self._from_companion(selector)
                    else:  # the GCS answering a companion: back to it
                        sock = key.fileobj
                        assert isinstance(sock, socket.socket)
                        with contextlib.suppress(OSError):
                            self.listen.sendto(sock.recv(65535), key.data)
                self._replay_due()
            for sock in (self.listen, self.replayer, *self.forward.values()):
                sock.close()

    def _from_companion(self, selector: selectors.BaseSelector) -> None:
        try:
            data, address = self.listen.recvfrom(65535)
        except OSError:  # an ICMP error for an earlier datagram back to a companion
            return
        sock = self.forward.get(address)
        if sock is None:
            sock = self.forward[address] = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            selector.register(sock, selectors.EVENT_READ, address)
        sock.sendto(data, ("127.0.0.1", GCS_PORT))  # unconnected: no ICMP errors back
        self.forwarded += 1
        now_s = time.monotonic()
        self.first_s = now_s if self.first_s is None else self.first_s
        if self.forwarded % REPLAY_EVERY == 0 and now_s < self.first_s + CAPTURE_S:
            self.captured.append((now_s + REPLAY_DELAY_S, data))

    def _replay_due(self) -> None:
        while self.captured and self.captured[0][0] <= time.monotonic():
            self.replayer.sendto(self.captured.popleft()[1], ("127.0.0.1", GCS_PORT))
            self.replayed += 1


def _events(records: list[tuple[str, float, dict[str, Any]]], event: str) -> list[float]:
    return [
        t for topic, t, r in records if topic == topics.COMPANION_EVENTS and r["event"] == event
    ]


def _counters(out: Path) -> tuple[dict[str, dict[str, int]], list[tuple[str, float, Any]]]:
    """Each app's last ``/app/counters`` record, by app, and every record of the run."""
    records = list(read_records(out / "run.mcap"))
    counters = {r["app"]: r["counters"] for t, _, r in records if t == topics.APP_COUNTERS}
    return counters, records


def _drops(counters: dict[str, int]) -> int:
    """What an app's ``/app/counters`` record says it dropped or refused, summed."""
    total = 0
    for key, value in counters.items():
        if key.rsplit(".", 1)[-1].removeprefix("link_") in DROPS:
            total += value
    return total


@pytest.mark.udp
@pytest.mark.slow
def test_a_sprayed_live_run_reaches_every_goal_and_alerts_as_undisturbed_runs_do(
    tmp_path: Path,
) -> None:
    cleans = [tmp_path / f"clean{k}" for k in range(len(CLEAN_PORT_OFFSETS))]
    procs = []
    for out, offset in zip(cleans, CLEAN_PORT_OFFSETS, strict=True):
        procs.append(_run(out, offset))
        _wait_until_started(out)  # start-ups one after the other: they are what costs CPU
    delays, regions_clean = [], []
    for proc, out in zip(procs, cleans, strict=True):
        metrics = _finish(proc, out)
        assert metrics["goal_reached_fraction"] == 1.0, metrics
        assert metrics["detection_delay_s"] is not None, metrics
        delays.append(metrics["detection_delay_s"])
        counters, _ = _counters(out)
        regions_clean.append(
            {
                app: c["regions.received"]
                for app, c in counters.items()
                if app.startswith("companion/")
            }
        )
    paused = warm_up(load_scenario_file(None, {"scenario.duration_s": 10.0}), "aware", 4.0)
    seeds = [data for datagrams in paused.seeds.values() for _, data in datagrams]
    out = tmp_path / "sprayed"
    sprayer, relay = Sprayer(out, seeds), Relay()
    relay.thread.start()
    proc = _run(out, relay=True)
    sprayer.thread.start()
    try:
        metrics = _finish(proc, out)
    finally:
        sprayer.stop.set()
        relay.stop.set()
        sprayer.thread.join(timeout=5)
        relay.thread.join(timeout=5)
    assert all(n >= PER_APP for n in sprayer.sent.values()), sprayer.sent
    assert metrics["goal_reached_fraction"] == 1.0, metrics
    assert metrics["detection_delay_s"] is not None
    assert metrics["detection_delay_s"] <= max(delays) + ALERT_SLACK_S, (metrics, delays)
    counters, records = _counters(out)
    companions = {app: c for app, c in counters.items() if app.startswith("companion/")}
    assert len(companions) == 4
    assert all(c["companion.autopilot_lost"] == 0 for c in companions.values())
    assert all(c["companion.handler_errors"] == 0 for c in companions.values())
    assert counters["gcs"]["handler_errors"] == counters["sim"]["handler_errors"] == 0
    assert _events(records, "gcs_lost") == [] and _events(records, "autopilot_lost") == []
    # The relay's replays are refused as replays, it never becomes a peer, and every
    # companion is served as many regions as undisturbed (the relay left them 4-5
    # of ~80): at most the alert's slack and a little jitter fewer.
    # Each replayed datagram holds at least one packet refused as replayed, unless the
    # kernel's full receive buffer dropped it first (the spray fills it: ``kernel_overflow``,
    # any datagram). A companion's reports go three to a packet, so a replayed datagram holds
    # about one packet, and the replays captured in the run's last second, which came after
    # the GCS had stopped, are no longer covered by the others' extra packets: none is made.
    assert relay.replayed > 100 and relay.forward.keys()
    gcs = counters["gcs"]
    assert gcs["replayed"] + gcs.get("kernel_overflow", 0) >= relay.replayed, gcs
    assert counters["gcs"]["peers_live"] == 4  # the relay's replaying socket is none
    for app, c in companions.items():
        fewest = min(clean[app] for clean in regions_clean)
        assert c["regions.received"] >= 0.8 * fewest, (app, c["regions.received"], fewest)
    # Every rejection counted: random bytes are never genuine, so each app counted at least
    # as many drops as it was sent random bytes (mutated MAVLink adds more).
    drops = {"sim": _drops(counters["sim"]), "gcs": _drops(counters["gcs"])}
    drops["companion"] = sum(_drops(c) for c in companions.values())
    for app, garbage in sprayer.garbage.items():
        assert drops[app] >= garbage, (app, drops, sprayer.garbage)
