"""The lockstep byte router: wiring, order and latency semantics, determinism."""

from __future__ import annotations

import pytest

from ridsafe.common import codec
from ridsafe.common import messages as m
from ridsafe.common.router import ByteRouter, Wire
from ridsafe.common.shell import Datagrams
from ridsafe.sim_backend.config import SimConfig
from ridsafe.sim_backend.world import SimBackend
from tests.sim_backend.helpers import scenario


class Recorder:
    """A core that logs what it got and sends a numbered datagram on ``send_on`` each step."""

    def __init__(self, name: str, send_on: str) -> None:
        self.name = name
        self.send_on = send_on
        self.got: list[tuple[float, str, bytes]] = []
        self.sent = 0

    def handle(self, now_s: float, inbound: Datagrams) -> Datagrams:
        self.got.extend((now_s, endpoint, data) for endpoint, data in inbound)
        self.sent += 1
        return [(self.send_on, f"{self.name}{self.sent}".encode()), ("nowhere", b"x")]


def test_later_cores_hear_the_same_step_earlier_ones_the_next() -> None:
    a, b = Recorder("a", "out"), Recorder("b", "in")
    router = ByteRouter({"a": a, "b": b}, [Wire(("a", "out"), ("b", "in"))], order=["a", "b"])
    router.step(0.1)
    router.step(0.2)
    assert b.got == [(0.1, "in", b"a1"), (0.2, "in", b"a2")]  # same step
    assert a.got == [(0.2, "out", b"b1")]  # next step
    assert router.undeliverable == 4 and router.delivered == 4


def test_bad_wiring_is_refused() -> None:
    a = Recorder("a", "out")
    with pytest.raises(ValueError, match="unknown core"):
        ByteRouter({"a": a}, [Wire(("a", "out"), ("z", "in"))], order=["a"])
    with pytest.raises(ValueError, match="wired twice"):
        ByteRouter(
            {"a": a}, [Wire(("a", "out"), ("a", "in")), Wire(("a", "out"), ("a", "x"))], ["a"]
        )
    with pytest.raises(ValueError, match="order"):
        ByteRouter({"a": a}, [], order=[])


class Station:
    """Arms vehicle 1 in GUIDED and takes off, through real MAVLink bytes."""

    def __init__(self) -> None:
        self.link = codec.MavlinkLink(255, 190)
        self.acks: list[m.CommandAck] = []
        self.script = [
            m.CommandLong(1, 1, m.MavCmd.DO_SET_MODE, 0, (1, 4, 0, 0, 0, 0, 0)),
            m.CommandLong(1, 1, m.MavCmd.COMPONENT_ARM_DISARM, 0, (1, 0, 0, 0, 0, 0, 0)),
            m.CommandLong(1, 1, m.MavCmd.NAV_TAKEOFF, 0, (0, 0, 0, 0, 0, 0, 15)),
        ]

    def handle(self, now_s: float, inbound: Datagrams) -> Datagrams:
        for _, data in inbound:
            self.acks.extend(
                r.message for r in self.link.feed(data) if isinstance(r.message, m.CommandAck)
            )
        if self.script and len(self.acks) == 3 - len(self.script):
            return [("sim", self.link.pack(self.script.pop(0)))]
        return []


def test_a_station_flies_the_sim_through_the_router_deterministically() -> None:
    def run() -> tuple[list[int], list[float]]:
        sim = SimBackend(scenario(1), SimConfig())
        station = Station()
        router = ByteRouter(
            {"sim": sim, "station": station},
            [Wire(("sim", "v1/gcs"), ("station", "sim"))],
            order=["sim", "station"],
        )
        for k in range(1, 501):
            router.step(k * 0.02)
        return [a.result for a in station.acks], sim.truth().p_enu_m[0].tolist()

    results, position = run()
    assert results == [0, 0, 0]
    assert position[2] == pytest.approx(15.0, abs=0.5)
    assert run() == (results, position)
