"""Signing that holds (issue 14): anti-replay state is per signing stream (link id, system,
component), shared by every peer link of the GCS, so a relay that re-sends a companion's
captured signed packets from a new socket is refused and counted, the companion keeps being
served and its reply address does not move to the relay."""

from __future__ import annotations

from ridsafe.common import codec
from ridsafe.common import messages as m
from ridsafe.gcs.gcs import peer_endpoint
from tests.gcs.test_gcs_core import KEY, FakePipeline, GcsPair, companion_heartbeat, counters


def _relayed_run(relay: bool) -> GcsPair:
    """10 s of companion c1 beating at 1 Hz; with ``relay``, from 3 s on a relay re-sends
    c1's last three captured packets from its own socket at every step."""
    signing = codec.SigningConfig(KEY, initial_timestamp=1_000)
    pair = GcsPair(n_companions=1, signing=signing, pipeline=FakePipeline(alert_at_s=0.0))
    pair.add_companion("relay", 1, None)  # the relay's socket; it only re-sends bytes
    captured: list[bytes] = []
    while pair.t_s <= 10.0 + 1e-9:
        beat = abs(pair.t_s - round(pair.t_s)) < 1e-9
        raw: list[tuple[str, bytes]] = []
        if beat:
            packet = pair.links["c1"].pack(companion_heartbeat())
            captured.append(packet)
            raw.append((peer_endpoint("c1"), packet))
        if relay and pair.t_s > 3.0 and captured:
            raw.append((peer_endpoint("relay"), b"".join(captured[-3:])))
        pair.step(raw=raw)
    return pair


def test_a_relay_replaying_signed_packets_from_a_new_socket_changes_nothing() -> None:
    pair = _relayed_run(relay=True)
    c = counters(pair)
    assert pair.gcs.replay.replayed > 0
    assert c["link_rejected_signature"] == pair.gcs.replay.replayed
    assert pair.gcs.sysid_peers == {1: "c1"}
    assert pair.gcs.live_peers == ("c1",)
    assert pair.received["relay"] == []
    late = [t for t, r in pair.received["c1"] if t > 3.0]
    assert late and max(late) >= 9.9
    assert pair.messages("c1", m.UnsafeRegionMsg)
    # what the companion receives is exactly what it receives with no relay at all
    undisturbed = _relayed_run(relay=False)
    assert undisturbed.gcs.replay.replayed == 0
    got = [(t, r.message, r.src_system, r.src_component) for t, r in pair.received["c1"]]
    expected = [
        (t, r.message, r.src_system, r.src_component) for t, r in undisturbed.received["c1"]
    ]
    assert got == expected


def test_a_stream_reappearing_from_a_new_port_with_an_old_timestamp_is_refused() -> None:
    signing = codec.SigningConfig(KEY, initial_timestamp=1_000)
    pair = GcsPair(n_companions=1, signing=signing, pipeline=FakePipeline(alert_at_s=0.0))
    pair.run(2.0)  # c1's stream is at timestamp ~1_003
    pair.add_companion("new-port", 1, codec.SigningConfig(KEY, initial_timestamp=900))
    pair.step({"new-port": [companion_heartbeat()]})
    assert pair.gcs.replay.replayed == 1
    assert pair.received["new-port"] == []
    pair.add_companion("fresh", 1, codec.SigningConfig(KEY, initial_timestamp=10**7))
    pair.step({"fresh": [companion_heartbeat()]})  # same stream, newer: a restart, accepted
    assert "fresh" in pair.gcs.live_peers
