"""Signing on the companion <-> autopilot link (issue 14, optional as in ArduPilot): with a key
set on both ends, a local process that sends valid MAVLink with the companion's ids before
the companion starts does not win the sim port's peer lock, and the genuine companion does;
without a key it does win (why the option exists). Over real UDP on 127.0.0.1; and a
lockstep run with ``run.sign_autopilot_links`` flies."""

from __future__ import annotations

import pytest

from ridsafe.common import codec
from ridsafe.common import messages as m
from ridsafe.common.logsink import NullSink
from ridsafe.common.udp import Address, UdpEndpoint
from ridsafe.companion.mission import Phase
from ridsafe.sim_backend import world
from ridsafe.sim_backend.world import EndpointKind, endpoint_name
from ridsafe.tools.run import lockstep
from ridsafe.tools.run.scenario import load_scenario_file, with_aircraft
from tests.common.test_peer_lock import COMPANION_IDS, SimOverUdp

KEY = codec.SigningConfig(bytes(range(32)), codec.signing_timestamp_from_unix(1_700_000_000.0))


def _early_impostor(signing: codec.SigningConfig | None) -> tuple[SimOverUdp, UdpEndpoint]:
    """The sim's port, and an impostor that speaks (unsigned, CRC-valid, the companion's
    ids) from the start; the companion joins at 2 s."""
    sim = SimOverUdp(signing)
    impostor = UdpEndpoint(remote=sim.port.local_address)
    forger = codec.MavlinkLink(*COMPANION_IDS)
    sim.speaks = False

    def extra(now_s: float) -> None:
        impostor.send(forger.pack(m.Heartbeat(18, 8, 0, 0, 4)))
        sim.speaks = now_s >= 2.0

    sim.extra = extra
    return sim, impostor


def _peer(sim: SimOverUdp) -> Address | None:
    """The sim port's locked peer now."""
    return sim.runner.locks["v1/companion"].address


@pytest.mark.udp
def test_with_a_key_an_early_unsigned_impostor_never_wins_the_port() -> None:
    sim, impostor = _early_impostor(KEY)
    try:
        sim.run(1.5)
        assert _peer(sim) is None  # nothing signed yet: no peer
        telemetry = sim.run(5.0)
        assert _peer(sim) == sim.companion.local_address
        assert sim.port.destination == sim.companion.local_address
        counters = sim.backend.counter_values()
        assert counters["not_from_locked_peer"] > 0  # the impostor, dropped and counted
    finally:
        sim.close()
        impostor.close()
    assert telemetry > 20  # signed telemetry reached the companion (its parser has the key)


@pytest.mark.udp
def test_without_a_key_the_early_impostor_wins_the_port() -> None:
    sim, impostor = _early_impostor(None)
    try:
        sim.run(3.0)
        lock = sim.runner.locks["v1/companion"]
        assert lock.address == impostor.local_address
    finally:
        sim.close()
        impostor.close()


@pytest.mark.udp
def test_a_signed_sim_port_refuses_the_unsigned_companion_and_answers_no_one() -> None:
    sim = SimOverUdp(KEY)
    sim.link = codec.MavlinkLink(*COMPANION_IDS)  # a companion without the key
    try:
        telemetry = sim.run(3.0)
        assert sim.runner.locks["v1/companion"].address is None
        assert sim.backend.counter_values()["not_from_locked_peer"] > 0  # dropped, counted
    finally:
        sim.close()
    assert telemetry == 0


def test_a_lockstep_run_with_signed_autopilot_links_flies() -> None:
    overrides = {"run.sign_autopilot_links": True, "scenario.duration_s": 30.0}
    run = lockstep.build(load_scenario_file(None, overrides), "aware", NullSink())
    while run.t_s < 25.0:
        run.step()
    assert all(c.phase in (Phase.CRUISE, Phase.ARRIVED) for c in run.companions.values())
    for sysid, companion in run.companions.items():
        port = run.sim.shell.endpoints[endpoint_name(sysid, EndpointKind.COMPANION)]
        assert port.link.signing is not None and port.link.counters.accepted > 0
        own = companion.shell.endpoints["autopilot"].link
        assert own.counters.rejected_signature == 0 and own.counters.accepted > 100
        # the transponder's reports of the RID it heard came signed too (sent as messages)
        assert companion.observations.counters.heard > 0


def test_a_signed_fleet_hears_every_rid_broadcast_the_radio_delivers() -> None:
    """Eight aircraft: a tick carries more receptions than the sim frames together
    (``world._FRAMED_TOGETHER_FROM``), which a signed link cannot take; every reception still
    reaches its companion, signed, as a message of its own."""
    overrides = {"run.sign_autopilot_links": True, "scenario.duration_s": 12.0}
    run = lockstep.build(with_aircraft(load_scenario_file(None, overrides), 8), "aware", NullSink())
    delivered, busiest = 0, 0  # to the aircraft with a companion (the spoofer hears too)
    while run.t_s < 10.0:
        run.step()
        delivered += sum(1 for r in run.sim.last_heard.receiver.tolist() if r + 1 in run.companions)
        busiest = max(busiest, len(run.sim.last_heard))
    assert delivered > 200 and busiest >= world._FRAMED_TOGETHER_FROM
    heard = sum(c.receiver.counters()["frames"] for c in run.companions.values())
    assert heard == delivered
    for companion in run.companions.values():
        link = companion.shell.endpoints["autopilot"].link
        assert link.counters.rejected_signature == 0
