"""The app shell: endpoints, sender checks, outbox, datagram joining, counters; in memory and
over real UDP sockets on 127.0.0.1 with real MAVLink bytes (pymavlink as the other end)."""

from __future__ import annotations

import select
import time
from dataclasses import replace

import pytest

from ridsafe.common import messages as m
from ridsafe.common.codec import MavlinkLink, Received, SigningConfig
from ridsafe.common.dialect import ridsafe_v20 as mav
from ridsafe.common.shell import (
    MAX_DATAGRAM_BYTES,
    AppShell,
    Endpoint,
    from_system,
    join_datagrams,
    not_from_systems,
)
from ridsafe.common.udp import UdpEndpoint

HEARTBEAT = m.Heartbeat(18, 8, 0, 0, 4)


def _shell() -> AppShell:
    shell = AppShell("test")
    shell.add(Endpoint("autopilot", MavlinkLink(3, 191), accept=from_system(3, (1, 236))))
    shell.add(Endpoint("gcs", MavlinkLink(3, 191)))
    return shell


def test_datagrams_are_joined_up_to_the_cap_and_no_packet_is_split() -> None:
    packets = [bytes([k]) * 300 for k in range(10)]
    datagrams = join_datagrams(packets)
    assert b"".join(datagrams) == b"".join(packets)
    assert all(len(d) <= MAX_DATAGRAM_BYTES for d in datagrams)
    assert [len(d) for d in datagrams] == [1200, 1200, 600]
    assert join_datagrams([bytes(2000), b"x"]) == [bytes(2000), b"x"]  # too long: alone


def test_accepted_messages_come_out_with_their_endpoint_and_the_rest_is_counted() -> None:
    shell = _shell()
    autopilot, transponder, stranger = MavlinkLink(3, 1), MavlinkLink(3, 236), MavlinkLink(4, 1)
    other_component = MavlinkLink(3, 100)
    inbound = [
        ("autopilot", autopilot.pack(HEARTBEAT) + transponder.pack(HEARTBEAT)),
        ("autopilot", stranger.pack(HEARTBEAT) + other_component.pack(HEARTBEAT)),
        ("gcs", stranger.pack(HEARTBEAT)),  # no check on this endpoint
        ("nowhere", autopilot.pack(HEARTBEAT)),
    ]
    got = [(e.name, r.src_system, r.src_component) for e, r in shell.receive(inbound)]
    assert got == [("autopilot", 3, 1), ("autopilot", 3, 236), ("gcs", 4, 1)]
    assert shell.counters.as_dict() == {
        "datagrams_in": 3,
        "datagrams_out": 0,
        "unknown_endpoint": 1,
        "handler_errors": 0,
        "foreign_system": 1,
        "other_component": 1,
    }


def test_an_opener_makes_endpoints_on_demand_or_says_why_not() -> None:
    def opener(name: str) -> Endpoint | str | None:
        if name.startswith("peer@"):
            return Endpoint(name, MavlinkLink(255, 190), accept=not_from_systems((0, 255)))
        return "full" if name == "late" else None

    shell = AppShell("gcs", opener)
    sender, bad = MavlinkLink(7, 191), MavlinkLink(0, 191)
    inbound = [
        ("peer@a", sender.pack(HEARTBEAT)),
        ("peer@a", bad.pack(HEARTBEAT)),
        ("late", sender.pack(HEARTBEAT)),
        ("junk", sender.pack(HEARTBEAT)),
    ]
    assert [e.name for e, _ in shell.receive(inbound)] == ["peer@a"]
    assert set(shell.endpoints) == {"peer@a"}
    counters = shell.counters.as_dict()
    assert (counters["bad_sysid"], counters["full"], counters["unknown_endpoint"]) == (1, 1, 1)
    removed = shell.remove("peer@a")
    assert removed is not None and shell.link_totals().accepted == 2  # kept after removal


def test_a_broadcast_is_framed_by_each_links_own_sequence_and_signature() -> None:
    key = bytes(range(32))
    shell = AppShell("gcs")
    shell.add(Endpoint("a", MavlinkLink(255, 190, SigningConfig(key, 1000))))
    plain = shell.add(Endpoint("b", MavlinkLink(255, 190)))
    plain.send(HEARTBEAT)  # b's sequence is one ahead of a's
    shell.broadcast(["a", "b"], [HEARTBEAT, m.SystemTime(1_700_000_000.0, 2.0)])
    out = dict(shell.flush())
    assert shell.counters.datagrams_out == 2
    reference_a = MavlinkLink(7, 191, SigningConfig(key))
    got_a = reference_a.feed(out["a"])
    assert [r.message for r in got_a] == [HEARTBEAT, m.SystemTime(1_700_000_000.0, 2.0)]
    assert all(r.signed for r in got_a) and reference_a.counters.rejected_signature == 0
    assert _sequences(out["b"]) == [0, 1, 2]
    assert _sequences(out["a"]) == [0, 1]
    assert shell.flush() == []  # the outbox was emptied


def _sequences(datagram: bytes) -> list[int]:
    parser = mav.MAVLink(None)
    return [msg.get_seq() for msg in parser.parse_buffer(datagram) or []]


def test_send_from_another_component_of_the_same_channel() -> None:
    shell = AppShell("sim")
    shell.add(Endpoint("v1/companion", MavlinkLink(1, 1), senders={236: MavlinkLink(1, 236)}))
    shell.send("v1/companion", HEARTBEAT)
    shell.send("v1/companion", HEARTBEAT, component=236)
    ((name, data),) = shell.flush()
    got = MavlinkLink(1, 191).feed(data)
    assert name == "v1/companion" and [r.src_component for r in got] == [1, 236]


# --- over real UDP ------------------------------------------------------------------------


def _wait(endpoint: UdpEndpoint, count: int, timeout_s: float = 2.0) -> list[bytes]:
    got: list[bytes] = []
    deadline = time.monotonic() + timeout_s
    while len(got) < count and time.monotonic() < deadline:
        select.select([endpoint], [], [], max(0.0, deadline - time.monotonic()))
        got.extend(data for data, _ in endpoint.recv_all())
    return got


@pytest.mark.udp
def test_a_shell_behind_a_real_socket_talks_to_pymavlink() -> None:
    """pymavlink's own encoder and parser on one socket, the shell on the other: what the
    shell receives is the pymavlink message as a domain message, what it sends pymavlink
    reads with a valid CRC."""
    with UdpEndpoint() as app_socket, UdpEndpoint() as peer_socket:
        shell = _shell()
        peer = mav.MAVLink(None, srcSystem=3, srcComponent=1)
        raw = mav.MAVLink_system_time_message(1_700_000_000_000_000, 2500)
        peer_socket.send(bytes(raw.pack(peer)), app_socket.local_address)
        (data,) = _wait(app_socket, 1)
        got: list[Received] = [r for _, r in shell.receive([("autopilot", data)])]
        assert [r.message for r in got] == [m.SystemTime(1_700_000_000.0, 2.5)]

        shell.send("autopilot", HEARTBEAT)
        shell.send("autopilot", m.SystemTime(1_700_000_001.0, 3.5))
        for _, datagram in shell.flush():
            app_socket.send(datagram, peer_socket.local_address)
        (reply,) = _wait(peer_socket, 1)
        parsed = mav.MAVLink(None).parse_buffer(reply) or []
        assert [p.get_type() for p in parsed] == ["HEARTBEAT", "SYSTEM_TIME"]
        assert parsed[1].time_unix_usec == 1_700_000_001_000_000
        assert (parsed[0].get_srcSystem(), parsed[0].get_srcComponent()) == (3, 191)


def test_a_batch_with_a_report_that_does_not_fit_loses_that_report_alone() -> None:
    """``send_all`` encodes a batch of reports together, three to a pack; when that fails,
    each pack goes by ``send`` (and the reports of the one that does not fit one by one), in
    order."""
    fits = m.Observation(
        1.0, 36.1, -86.8, 200.0, 36.1, -86.8, 210.0, 1.0, -70.0, 0.0, 1.0, 0.0, "A"
    )
    too_long_id = replace(fits, uas_id="X" * 21)
    shell = _shell()
    shell.send_all("gcs", [m.ObservationRows.of([fits, fits, fits, too_long_id, fits])])
    endpoint = shell.endpoints["gcs"]
    assert endpoint.unencodable == 1 and len(endpoint.outbox) == 2
    ((_, data),) = shell.flush()
    received = MavlinkLink(255, 190).feed(data)
    assert isinstance(received[0].message, m.ObservationRows)
    assert received[0].message.observations() == [fits, fits, fits]
    assert [r.message for r in received[1:]] == [fits]


def test_a_batch_of_reports_goes_three_to_a_pack() -> None:
    fits = m.Observation(
        1.0, 36.1, -86.8, 200.0, 36.1, -86.8, 210.0, 1.0, -70.0, 0.0, 1.0, 0.0, "A"
    )
    shell = _shell()
    shell.send_all("gcs", [m.ObservationRows.of([replace(fits, t_s=k) for k in range(7)])])
    assert len(shell.endpoints["gcs"].outbox) == 3  # packs of 3, 3 and 1
    ((_, data),) = shell.flush()
    (received,) = MavlinkLink(255, 190, columnar=True).feed(data)
    assert isinstance(received.message, m.ObservationRows)
    assert [o.t_s for o in received.message.observations()] == list(range(7))


def test_a_pack_of_reports_that_does_not_fit_goes_report_by_report() -> None:
    """Only the report that cannot be encoded is lost (and counted), not its pack-mates."""
    fits = m.Observation(
        1.0, 36.1, -86.8, 200.0, 36.1, -86.8, 210.0, 1.0, -70.0, 0.0, 1.0, 0.0, "A"
    )
    too_long_id = m.Observation(1.0, 36.1, -86.8, 200.0, 36.1, -86.8, 210.0, 1.0, -70.0, 0.0,
                                1.0, 0.0, "X" * 21)  # fmt: skip
    shell = _shell()
    shell.send("gcs", m.ObservationPack((fits, too_long_id, fits)))
    endpoint = shell.endpoints["gcs"]
    assert endpoint.unencodable == 1 and len(endpoint.outbox) == 2
    ((name, data),) = shell.flush()
    received = MavlinkLink(255, 190).feed(data)
    assert name == "gcs"
    assert [r.message for r in received] == [fits, fits]
