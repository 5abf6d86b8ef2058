"""The GCS core, h11-style: fake companions (``MavlinkLink`` sysid 1..4, compid 191) talk to
``Gcs.handle`` through an in-memory network of real MAVLink bytes; a small deterministic fake
pipeline stands in for the estimation pipeline.

Oracles: ENU positions from the points the reports were built from (wire quantisation
~1 cm); region centres back through ``frames.geodetic_to_enu``; the NED covariance written
out element by element from the ENU one (not through the permutation matrix).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import TypeVar

import numpy as np
import pytest

from ridsafe.common import codec, frames, pathloss, topics
from ridsafe.common import messages as m
from ridsafe.common.ellipsoid import inside
from ridsafe.common.logsink import MemorySink
from ridsafe.gcs.config import ClockSource, GcsConfig
from ridsafe.gcs.gcs import Gcs, peer_endpoint
from ridsafe.gcs.outputs import ned_upper_triangle
from ridsafe.gcs.pipeline import EstimationPipeline
from ridsafe.gcs.pipeline_api import (
    AlertChange,
    CycleOutput,
    DetectorResult,
    ObservedClaim,
    TrackEstimate,
    UnsafeRegion,
    readonly,
)
from ridsafe.gcs.pipeline_config import ForcedAlertConfig, PipelineConfig
from tests.gcs.test_ingest import ORIGIN, SPOOF, observation

KEY = bytes(range(32))
COMPANION_COMPONENT = 191
CENTER_ENU_M = (120.0, -80.0, 55.0)
COV_ENU_M2 = ((40.0, 3.0, -2.0), (3.0, 90.0, 5.0), (-2.0, 5.0, 20.0))
V_ENU_M_S = (1.5, -2.5, 0.5)
TRACK_ID = 7
M = TypeVar("M", bound=m.Message)


class FakePipeline:
    """Records every call. Raises the forced alert on SPOOF at ``alert_at_s``; from then on one
    track and one region per cycle (fixed ENU values), a detector result per transmission;
    deletes the track at ``delete_at_s``; raises at ``fail_at_s``."""

    def __init__(
        self,
        alert_at_s: float = 5.0,
        delete_at_s: float = math.inf,
        fail_at_s: float | None = None,
        center_enu_m: tuple[float, float, float] = CENTER_ENU_M,
    ) -> None:
        self.alert_at_s = alert_at_s
        self.delete_at_s = delete_at_s
        self.fail_at_s = fail_at_s
        self.center_enu_m = center_enu_m
        self.calls: list[tuple[float, tuple[ObservedClaim, ...]]] = []
        self.raised = False
        self.deleted = False

    def step(self, now_s: float, transmissions: Sequence[ObservedClaim]) -> CycleOutput:
        self.calls.append((now_s, tuple(transmissions)))
        if self.fail_at_s is not None and abs(now_s - self.fail_at_s) < 1e-9:
            raise RuntimeError("numerical trouble")
        per_claim = tuple(
            (DetectorResult(t.uas_id, m.RidsafeDetector.NIS, 2.0, 9.0, False),)
            for t in transmissions
        )
        changes: tuple[AlertChange, ...] = ()
        if not self.raised and now_s >= self.alert_at_s - 1e-9:
            self.raised = True
            changes = (AlertChange(SPOOF, m.RidsafeDetector.FORCED, 1.0, 0.5, m.AlertState.RAISED),)
        if not self.raised or self.deleted:
            return CycleOutput(per_claim, changes)
        if now_s >= self.delete_at_s - 1e-9:
            self.deleted = True
            return CycleOutput(per_claim, changes, deleted_tracks=(SPOOF,))
        return CycleOutput(per_claim, changes, (self.track(now_s),), (self.region(now_s),))

    def track(self, now_s: float) -> TrackEstimate:
        return TrackEstimate(
            SPOOF,
            TRACK_ID,
            readonly(self.center_enu_m),
            readonly(COV_ENU_M2),
            readonly(V_ENU_M_S),
            readonly([0.3, 0.7]),
            fix=True,
            last_fix_s=now_s,
        )

    def region(self, now_s: float) -> UnsafeRegion:
        return UnsafeRegion(
            SPOOF,
            TRACK_ID,
            now_s,
            readonly(self.center_enu_m),
            readonly(COV_ENU_M2),
            readonly(V_ENU_M_S),
            chi2_threshold=7.8147,
            alpha=0.05,
            valid_until_s=now_s + 2.0,
            semi_axes_m=readonly([30.0, 20.0, 10.0]),
            axes_enu=readonly(np.eye(3)),
        )


class GcsPair:
    """A ``Gcs`` and fake companions ``c1..cN`` (sysid i) on an in-memory network."""

    def __init__(
        self,
        n_companions: int = 4,
        config: GcsConfig | None = None,
        pipeline: FakePipeline | None = None,
        signing: codec.SigningConfig | None = None,
    ) -> None:
        self.pipeline = pipeline if pipeline is not None else FakePipeline()
        self.sink = MemorySink()
        self.gcs = Gcs(config or GcsConfig(), ORIGIN, self.pipeline, self.sink, signing)
        self.links: dict[str, codec.MavlinkLink] = {}
        self.received: dict[str, list[tuple[float, codec.Received]]] = {}
        for i in range(1, n_companions + 1):
            self.add_companion(f"c{i}", i, signing)
        self.t_s = 0.0
        self.in_parts = False

    def add_companion(self, peer: str, sysid: int, signing: codec.SigningConfig | None) -> None:
        self.links[peer] = codec.MavlinkLink(sysid, COMPANION_COMPONENT, signing)
        self.received[peer] = []

    def step(
        self,
        send: Mapping[str, Sequence[m.Message]] | None = None,
        raw: Sequence[tuple[str, bytes]] = (),
        dt_s: float = 0.05,
    ) -> list[tuple[str, bytes]]:
        """One ``handle`` at the current time (``in_parts``: ``begin``, one ``receive`` per
        datagram, ``tick``), then advance by ``dt_s``."""
        inbound = [
            (peer_endpoint(peer), self.links[peer].pack_all(list(messages)))
            for peer, messages in (send or {}).items()
            if messages
        ]
        if self.in_parts:
            self.gcs.begin(self.t_s)
            for one in [*inbound, *raw]:
                self.gcs.receive(self.t_s, [one])
            outbound = self.gcs.tick(self.t_s)
        else:
            outbound = self.gcs.handle(self.t_s, [*inbound, *raw])
        for name, datagram in outbound:
            peer = name.removeprefix("companions@")
            self.received[peer].extend((self.t_s, r) for r in self.links[peer].feed(datagram))
        self.t_s = round(self.t_s + dt_s, 9)
        return outbound

    def run(self, until_s: float, alive: Sequence[str] | None = None) -> None:
        """Step to ``until_s`` (inclusive); live companions send a heartbeat every second."""
        peers = list(self.links) if alive is None else alive
        while self.t_s <= until_s + 1e-9:
            beat = abs(self.t_s - round(self.t_s)) < 1e-9
            self.step({p: [companion_heartbeat()] for p in peers} if beat else None)

    def messages(self, peer: str, kind: type[M]) -> list[tuple[float, M]]:
        return [(t, r.message) for t, r in self.received[peer] if isinstance(r.message, kind)]


def companion_heartbeat() -> m.Heartbeat:
    return m.Heartbeat(int(m.MavType.ONBOARD_CONTROLLER), int(m.MavAutopilot.INVALID), 0, 0, 4)


def rx_enu(sysid: int) -> tuple[float, float, float]:
    return (100.0 * sysid, -50.0 * sysid, 40.0 + sysid)


def report(sysid: int, t_s: float, rid_timestamp_s: float = 1200.0) -> m.Observation:
    return observation(
        t_s=t_s,
        rx_enu_m=rx_enu(sysid),
        rid_timestamp_s=rid_timestamp_s,
        rssi_dbm=-60.0 - sysid,
    )


def counters(pair: GcsPair) -> dict[str, int]:
    return pair.gcs.counter_values()


# --- inbound: reports -> transmissions ------------------------------------------------------


def test_reports_from_four_companions_reach_the_pipeline_as_one_transmission() -> None:
    pair = GcsPair()
    pair.run(0.95)
    pair.step({"c1": [report(1, 1.0)], "c2": [report(2, 1.0)]})  # t = 1.00
    pair.step({"c3": [report(3, 1.02)]})  # 1.05
    pair.step()  # 1.10
    pair.step({"c4": [report(4, 1.03)]})  # 1.15
    pair.run(2.0)
    with_data = [(t, txs) for t, txs in pair.pipeline.calls if txs]
    assert len(with_data) == 1
    t_cycle, (tx,) = with_data[0]
    assert t_cycle == pytest.approx(1.5)  # closes at 1.30, handed over at the next cycle
    assert tx.uas_id == SPOOF and tx.rid_timestamp_s == 1200.0
    assert tx.rx_sysid.tolist() == [1, 2, 3, 4]
    np.testing.assert_allclose(tx.rx_p_enu_m, [rx_enu(i) for i in (1, 2, 3, 4)], atol=0.02)
    np.testing.assert_allclose(tx.claimed_p_enu_m, [300.0, 400.0, 60.0], atol=0.02)
    assert tx.rssi_dbm.tolist() == [-61.0, -62.0, -63.0, -64.0]
    np.testing.assert_allclose(tx.rx_t_s, [1.0, 1.0, 1.02, 1.03], atol=1e-6)
    assert pair.gcs.sysid_peers == {1: "c1", 2: "c2", 3: "c3", 4: "c4"}


def test_a_transmission_closes_when_its_window_is_over_not_at_the_next_cycle() -> None:
    """Closed at the first step ``group_window_s`` after its first reception (1.30 s) and
    handed to the next cycle (1.50 s): a report that comes between the two is late, whatever
    the cycles' phase."""
    pair = GcsPair()
    pair.run(0.95)
    pair.step({"c1": [report(1, 1.0)]})  # t = 1.00
    pair.run(1.35)
    assert pair.gcs.ingest.open_groups == 0  # closed at 1.30, before any cycle took it
    pair.step({"c2": [report(2, 1.0)]})  # 1.40
    pair.run(2.0)
    ((t_cycle, (tx,)),) = [(t, txs) for t, txs in pair.pipeline.calls if txs]
    assert t_cycle == pytest.approx(1.5)
    assert tx.rx_sysid.tolist() == [1]
    assert counters(pair)["rejected_late"] == 1
    cycles = dict(pair.sink.on(topics.GCS_CYCLE))
    assert cycles[1.5]["n_transmissions"] == 1


def test_the_cycle_runs_every_quarter_second_and_logs_its_compute_time() -> None:
    pair = GcsPair()
    pair.run(3.0)
    times = [t for t, _ in pair.pipeline.calls]
    assert times == pytest.approx([0.25 * k for k in range(13)])
    cycles = pair.sink.on(topics.GCS_CYCLE)
    assert [t for t, _ in cycles] == times
    for _, record in cycles:
        assert set(topics.TOPICS[topics.GCS_CYCLE][1]) <= set(record)
        assert record["compute_ms"] >= record["pipeline_ms"] >= 0.0
        assert record["error"] is None


# --- outbound: alerts, regions, heartbeats --------------------------------------------------


def test_alerts_and_regions_reach_every_companion_in_their_frames() -> None:
    pair = GcsPair()
    pair.run(6.0)
    for peer in ("c1", "c2", "c3", "c4"):
        alerts = pair.messages(peer, m.SpoofAlert)
        assert alerts[0] == (5.0, m.SpoofAlert(5.0, 1.0, 0.5, 0, int(m.AlertState.RAISED), SPOOF))
        regions = [msg for _, msg in pair.messages(peer, m.UnsafeRegionMsg)]
        assert [r.t_s for r in regions] == [5.0, 5.25, 5.5, 5.75, 6.0]
    region = regions[-1]
    assert isinstance(region, m.UnsafeRegionMsg)
    assert region.uas_id == SPOOF and region.track_id == TRACK_ID and region.flags == 0
    assert region.valid_until_s == pytest.approx(7.0)  # min(6 + 2 from the pipeline, 6 + 1)
    back = frames.geodetic_to_enu(
        ORIGIN, region.center_lat_deg, region.center_lon_deg, region.center_alt_m
    )
    np.testing.assert_allclose(back, CENTER_ENU_M, atol=0.02)
    (ee, en, eu), (_, nn, nu), (_, _, uu) = COV_ENU_M2
    expected_ned = (nn, en, -nu, ee, -eu, uu)  # xx=NN, xy=NE, xz=ND, yy=EE, yz=ED, zz=DD
    np.testing.assert_allclose(region.cov_ned_m2, expected_ned, rtol=1e-6)
    np.testing.assert_allclose(region.v_ned_m_s, (-2.5, 1.5, -0.5), rtol=1e-6)
    assert region.chi2_threshold == pytest.approx(7.8147) and region.alpha == pytest.approx(0.05)


def test_cov_permutation_matches_the_matrix_product() -> None:
    rng = np.random.default_rng(3)
    a = rng.normal(size=(3, 3))
    cov = a @ a.T
    t = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    full = t @ cov @ t.T
    upper = [full[i, j] for i, j in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))]
    np.testing.assert_allclose(ned_upper_triangle(cov), upper, rtol=1e-12)


def test_gcs_heartbeats_at_one_hertz_as_a_ground_station() -> None:
    pair = GcsPair(n_companions=1)
    pair.run(5.0)
    beats = [(t, r) for t, r in pair.received["c1"] if isinstance(r.message, m.Heartbeat)]
    assert [t for t, _ in beats] == pytest.approx([0.0, 1.0, 2.0, 3.0, 4.0, 5.0])
    _, first = beats[0]
    assert (first.src_system, first.src_component) == (255, 190)
    assert first.message == m.Heartbeat(6, 8, 0, 0, int(m.MavState.ACTIVE))


def test_raised_alerts_are_repeated_so_a_late_joiner_learns_them() -> None:
    pair = GcsPair(n_companions=5)
    pair.run(7.2, alive=["c1", "c2", "c3", "c4"])
    assert pair.received["c5"] == []
    pair.run(8.5)
    late = pair.messages("c5", m.SpoofAlert)
    assert late and late[0][0] <= 8.25
    assert late[0][1] == m.SpoofAlert(5.0, 1.0, 0.5, 0, 1, SPOOF)  # the decision time
    assert [t for t, _ in pair.messages("c1", m.SpoofAlert)] == pytest.approx([5.0, 6.0, 7.0, 8.0])
    assert len(pair.sink.on(topics.ALERTS)) == 1  # logged once, when raised


def test_everything_a_cycle_decides_is_logged_per_topic() -> None:
    pair = GcsPair()
    pair.run(3.9)
    pair.step({"c1": [report(1, 3.95)], "c2": [report(2, 3.95)]})
    pair.run(5.0)
    (alert,) = pair.sink.on(topics.ALERTS)
    assert alert == (5.0, {**alert[1], "uas_id": SPOOF, "detector": "forced", "state": "raised"})
    assert [t for t, _ in pair.sink.on(topics.REGIONS)] == [5.0]
    _, region = pair.sink.on(topics.REGIONS)[0]
    assert region["center_enu_m"] == list(CENTER_ENU_M) and region["valid_until_s"] == 6.0
    assert region["cov_enu_m2"] == [list(row) for row in COV_ENU_M2]
    _, track = pair.sink.on(topics.TRACKS)[0]
    assert track["mode_probabilities"] == [0.3, 0.7] and track["fix"] is True
    (stats,) = pair.sink.on(topics.DETECTOR_STATS)
    assert stats[1] == {
        "uas_id": SPOOF,
        "detectors": {"nis": {"statistic": 2.0, "threshold": 9.0, "decision": False}},
    }
    for topic in (topics.ALERTS, topics.REGIONS, topics.TRACKS, topics.DETECTOR_STATS):
        for _, record in pair.sink.on(topic):
            assert set(topics.TOPICS[topic][1]) <= set(record)


def test_a_deleted_track_sends_its_last_region_flagged_deleted() -> None:
    pair = GcsPair(n_companions=2, pipeline=FakePipeline(delete_at_s=6.0))
    pair.run(7.0)
    regions = [msg for _, msg in pair.messages("c2", m.UnsafeRegionMsg)]
    assert isinstance(regions[-1], m.UnsafeRegionMsg)
    assert [r.flags for r in regions if isinstance(r, m.UnsafeRegionMsg)] == [0, 0, 0, 0, 1]
    assert regions[-1].t_s == 5.75 and regions[-1].valid_until_s == 6.0
    cycle = dict(pair.sink.on(topics.GCS_CYCLE))[6.0]
    assert cycle["deleted_tracks"] == [SPOOF]


class StrangerPipeline(FakePipeline):
    """Its region is a stranger's: no alert stands on it."""

    def region(self, now_s: float) -> UnsafeRegion:
        return dataclasses.replace(super().region(now_s), unconfirmed=True)


def test_a_strangers_region_goes_out_and_into_the_log_flagged_unconfirmed() -> None:
    pair = GcsPair(n_companions=2, pipeline=StrangerPipeline(delete_at_s=6.0))
    pair.run(7.0)
    regions = [msg for _, msg in pair.messages("c1", m.UnsafeRegionMsg)]
    unconfirmed, deleted = int(m.RegionFlags.UNCONFIRMED), int(m.RegionFlags.DELETED)
    assert [r.flags for r in regions] == [unconfirmed] * 4 + [deleted]
    assert [r["flags"] for _, r in pair.sink.on(topics.REGIONS)] == [unconfirmed] * 4


# --- faults: bad input, failing pipeline, dead and returning peers -------------------------


def test_garbage_and_bad_reports_are_counted_and_survived() -> None:
    pair = GcsPair(n_companions=3)
    junk = codec.MavlinkLink(9, COMPANION_COMPONENT)
    nan_rssi = junk.pack(dataclasses.replace(report(9, 0.5), rssi_dbm=math.nan))
    pair.run(0.45)
    pair.step(
        {"c2": [report(2, 0.5, 1300.0)], "c3": [observation(t_s=0.5, rssi_dbm=-200.0)]},
        raw=[
            ("companions@junk", np.random.default_rng(0).bytes(600)),
            ("companions@junk", junk.pack(companion_heartbeat())[:9]),
            ("companions@junk", nan_rssi),
            ("companions@c1", b"not mavlink at all"),
            ("sim/v1", b"wrong endpoint"),
        ],
    )
    pair.step({"c1": [report(1, 0.5, 1300.0)]})
    pair.run(1.5)
    c = counters(pair)
    assert c["link_bad_data"] >= 1 and c["link_truncated"] >= 1
    assert c["link_invalid_value"] == 1  # the NaN RSSI: the codec refuses it
    assert c["rejected_rssi_range"] == 1  # -200 dBm passes the codec, not the ingest
    assert c["unknown_endpoint"] == 1
    (tx,) = [tx for _, txs in pair.pipeline.calls for tx in txs]
    assert tx.rx_sysid.tolist() == [1, 2]
    assert "junk" not in pair.gcs.live_peers  # nothing valid came from it
    pair.gcs.finish(pair.t_s)
    (_, record), *_ = reversed(pair.sink.on(topics.APP_COUNTERS))
    assert record["app"] == "gcs" and record["counters"] == counters(pair)


def test_a_failing_pipeline_step_is_logged_and_the_gcs_goes_on() -> None:
    pair = GcsPair(n_companions=1, pipeline=FakePipeline(alert_at_s=1.0, fail_at_s=1.5))
    pair.run(2.0)
    cycles = dict(pair.sink.on(topics.GCS_CYCLE))
    assert cycles[1.5]["error"] == "RuntimeError: numerical trouble"
    assert cycles[1.75]["error"] is None and counters(pair)["pipeline_errors"] == 1
    assert [t for t, _ in pair.messages("c1", m.UnsafeRegionMsg)] == [1.0, 1.25, 1.75, 2.0]


def test_non_finite_regions_are_not_sent() -> None:
    pipeline = FakePipeline(alert_at_s=1.0, center_enu_m=(math.nan, 0.0, 50.0))
    pair = GcsPair(n_companions=1, pipeline=pipeline)
    pair.run(2.0)
    assert pair.messages("c1", m.UnsafeRegionMsg) == []
    assert counters(pair)["invalid_regions"] == 5 and pair.sink.on(topics.REGIONS) == []


def test_a_silent_companion_is_dropped_and_comes_back_when_it_speaks() -> None:
    pair = GcsPair(config=GcsConfig(peer_timeout_s=3.0), pipeline=FakePipeline(alert_at_s=0.0))
    pair.run(2.0)
    pair.run(8.0, alive=["c1", "c2", "c3"])  # c4 last heard at t = 2
    last_c4 = max(t for t, _ in pair.received["c4"])
    assert last_c4 == pytest.approx(5.0)  # dropped once not heard for more than 3 s
    assert "c4" not in pair.gcs.live_peers and counters(pair)["peers_timed_out"] == 1
    assert max(t for t, _ in pair.received["c1"]) == pytest.approx(8.0)
    pair.step({"c4": [companion_heartbeat()]})  # t = 8.05
    pair.run(9.0)
    assert any(t > 8.0 for t, _ in pair.messages("c4", m.UnsafeRegionMsg))
    assert "c4" in pair.gcs.live_peers


def test_a_system_that_moves_to_a_new_peer_is_served_there_only() -> None:
    """A restarted companion (new address) is served at once; its system id moves there,
    and the old address stops being served, once the old one has been silent for
    ``peer_timeout_s`` (before that, another address cannot take the system away)."""
    pair = GcsPair(n_companions=1, pipeline=FakePipeline(alert_at_s=0.0))
    pair.run(1.0)
    pair.add_companion("c1-restarted", 1, None)
    pair.step({"c1-restarted": [companion_heartbeat()]})  # t = 1.05
    assert pair.gcs.sysid_peers == {1: "c1"}
    pair.run(6.0, alive=["c1-restarted"])
    assert pair.gcs.sysid_peers == {1: "c1-restarted"}
    assert pair.gcs.live_peers == ("c1-restarted",)
    timeout_s = pair.gcs.config.peer_timeout_s
    assert max(t for t, _ in pair.received["c1"]) <= 1.0 + timeout_s + 0.1
    assert min(t for t, _ in pair.received["c1-restarted"]) <= 1.5  # the next cycle
    assert counters(pair)["sysid_moves_refused"] >= 1


def test_peers_are_bounded_and_a_dead_one_makes_room() -> None:
    pair = GcsPair(n_companions=3, config=GcsConfig(max_peers=2, peer_timeout_s=1.0))
    pair.run(0.5, alive=["c1", "c2"])
    pair.step({"c3": [companion_heartbeat()]})
    assert counters(pair)["peer_limit"] == 1 and pair.received["c3"] == []
    pair.run(3.0, alive=["c1"])  # c2 times out
    pair.step({"c3": [companion_heartbeat()]})
    assert set(pair.gcs.live_peers) == {"c1", "c3"} and counters(pair)["peers_evicted"] == 1


# --- signing ---------------------------------------------------------------------------------


def test_with_signing_unsigned_and_forged_packets_are_rejected_and_signed_pass() -> None:
    signing = codec.SigningConfig(KEY, initial_timestamp=1_000)
    pair = GcsPair(n_companions=1, signing=signing, pipeline=FakePipeline(alert_at_s=0.0))
    pair.add_companion("plain", 2, None)
    forger = codec.SigningConfig(bytes(32), initial_timestamp=5_000)
    pair.add_companion("forger", 3, forger)
    pair.run(0.95, alive=["c1", "plain", "forger"])
    pair.step({p: [report(int(pair.links[p].src_system), 1.0)] for p in pair.links})
    pair.run(2.0, alive=["c1", "plain", "forger"])
    (tx,) = [tx for _, txs in pair.pipeline.calls for tx in txs]
    assert tx.rx_sysid.tolist() == [1]
    c = counters(pair)
    assert c["link_rejected_signature"] == 2 * 3  # two peers, heartbeats at 0, 1, 2 + reports
    assert pair.gcs.live_peers == ("c1",)
    assert pair.received["plain"] == [] and pair.received["forger"] == []
    received = pair.received["c1"]  # c1's link only accepts signed packets
    assert received and all(r.signed for _, r in received)
    assert pair.messages("c1", m.UnsafeRegionMsg)


# --- clock -----------------------------------------------------------------------------------


def test_peer_clock_locks_on_the_first_report_when_the_gcs_starts_late() -> None:
    config = GcsConfig(clock=ClockSource.PEERS)
    pair = GcsPair(n_companions=2, config=config, pipeline=FakePipeline(alert_at_s=32.0))
    pair.run(1.0)
    assert pair.pipeline.calls == [] and pair.gcs.sim_time_s(1.0) is None
    assert pair.messages("c1", m.Heartbeat)  # heartbeats go out before the lock
    pair.step({"c1": [report(1, 30.4, 1400.0)]})  # runner time 1.05, sim time 30.4
    pair.step({"c2": [report(2, 30.42, 1400.0)]})
    pair.run(4.0)
    assert counters(pair)["observations_accepted"] == 2
    times = [t for t, _ in pair.pipeline.calls]
    assert times[0] == pytest.approx(30.5) and times[-1] == pytest.approx(33.25)
    (tx,) = [tx for _, txs in pair.pipeline.calls for tx in txs]
    assert tx.rx_sysid.tolist() == [1, 2]
    assert pair.messages("c1", m.SpoofAlert)[0][1].t_s == pytest.approx(32.0)


def test_local_clock_rejects_reports_from_the_future() -> None:
    pair = GcsPair(n_companions=1)
    pair.run(1.0)
    pair.step({"c1": [report(1, 30.4)]})
    assert counters(pair)["rejected_future_time"] == 1


# --- with the real estimation pipeline -------------------------------------------------------


def test_the_real_pipeline_behind_the_gcs_localises_a_forced_spoofer() -> None:
    """Noise-free RSSI of a hovering spoofer at eight receivers spread in 3-D (six on one
    ring admit a second transmitter position that fits the RSSI as well), forced alert at
    2 s: every companion gets the FORCED alert and regions centred on the true position."""

    forced = ForcedAlertConfig(enabled=True, uas_id=SPOOF, time_s=2.0)
    pipeline = EstimationPipeline(PipelineConfig(forced_alert=forced))
    sink = MemorySink()
    gcs = Gcs(GcsConfig(), ORIGIN, pipeline, sink)
    true_enu = np.array([50.0, 80.0, 60.0])
    receivers = {
        i: np.array([(120.0 + 40.0 * i) * math.cos(i), (120.0 + 40.0 * i) * math.sin(i), 15 * i])
        for i in range(1, 9)
    }
    links = {i: codec.MavlinkLink(i, COMPANION_COMPONENT) for i in receivers}
    regions: list[m.UnsafeRegionMsg] = []
    for k in range(161):  # 8 s of 0.05 s ticks
        t = k * 0.05
        inbound = []
        if k % 20 == 0:  # a broadcast every second, heard by all
            for i, rx in receivers.items():
                rssi = float(pathloss.received_power_dbm(20.0, np.linalg.norm(true_enu - rx)))
                obs = observation(t, tuple(rx), (100.0, 130.0, 60.0), 1200.0 + t, rssi)
                inbound.append((peer_endpoint(f"c{i}"), links[i].pack(obs)))
        for name, data in gcs.handle(t, inbound):
            got = [r.message for r in links[int(name[-1])].feed(data)]
            regions.extend(x for x in got if isinstance(x, m.UnsafeRegionMsg) and name[-1] == "1")
    (alert,) = sink.on(topics.ALERTS)
    assert alert[0] == pytest.approx(2.0) and alert[1]["detector"] == "forced"
    assert regions, gcs.counter_values()
    last = regions[-1]
    centre = frames.geodetic_to_enu(
        ORIGIN, last.center_lat_deg, last.center_lon_deg, last.center_alt_m
    )
    # Noise-free RSSI: the estimate is horizontally tight and the ellipsoid holds the truth
    # (six broadcasts pin altitude, the weak axis, less than position).
    assert np.hypot(*(centre - true_enu)[:2]) < 2.0
    cov_enu = frames.cov_ned_to_enu(_cov_matrix(last.cov_ned_m2))
    assert inside(true_enu, centre, cov_enu, last.chi2_threshold)


def _cov_matrix(upper: tuple[float, ...]) -> np.ndarray:
    xx, xy, xz, yy, yz, zz = upper
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def test_detector_stats_are_one_record_per_claim_with_every_detectors_verdict() -> None:
    """Two claims of one transmitter in a cycle stay two records, even where their detectors
    differ; each holds its own detectors' verdicts; a claim with none logs nothing."""
    nis, mlat, cusum = m.RidsafeDetector.NIS, m.RidsafeDetector.MLAT, m.RidsafeDetector.CUSUM
    per_claim = (
        (DetectorResult("A", nis, 1.0, 9.0, False), DetectorResult("A", mlat, 2.0, 8.0, False)),
        (DetectorResult("A", cusum, 10.0, 9.0, True),),  # A's next claim
        (),
        (DetectorResult("B", nis, 4.0, 9.0, False),),
    )

    class Fixed:
        def step(self, now_s: float, claims: Sequence[ObservedClaim]) -> CycleOutput:
            return CycleOutput(per_claim)

    sink = MemorySink()
    Gcs(GcsConfig(), ORIGIN, Fixed(), sink).handle(0.0, [])
    records = [r for _, r in sink.on(topics.DETECTOR_STATS)]
    assert [(r["uas_id"], list(r["detectors"])) for r in records] == [
        ("A", ["nis", "mlat"]),
        ("A", ["cusum"]),
        ("B", ["nis"]),
    ]
    assert records[1]["detectors"]["cusum"] == {
        "statistic": 10.0,
        "threshold": 9.0,
        "decision": True,
    }


def _scripted(pair: GcsPair) -> list[tuple[bool, list[tuple[str, bytes]], int]]:
    """Ten seconds of heartbeats, reports of a transmission a second (heard by half the
    companions in each of two steps) and garbage. Per step: ``quiet_at`` before it, the
    datagrams it sent, the records it logged."""
    steps = []
    for k in range(200):
        send: dict[str, list[m.Message]] = {}
        if k % 20 == 0:
            send = {peer: [companion_heartbeat()] for peer in pair.links}
        if k % 20 in (3, 4):
            for i, peer in enumerate(pair.links, start=1):
                if (i + k) % 2:
                    send.setdefault(peer, []).append(report(i, pair.t_s, 1200.0 + k // 20))
        raw = [(peer_endpoint("c1"), b"\xfd\x09garbage")] if k % 7 == 0 else []
        quiet, logged = pair.gcs.quiet_at(pair.t_s), len(pair.sink.records)
        sent = pair.step(send, raw)
        steps.append((quiet, sent, len(pair.sink.records) - logged))
    return steps


def _off_cycle(clock: ClockSource) -> GcsConfig:
    """Heartbeats and counters due on steps of their own, not only the cycles'."""
    return GcsConfig(clock=clock, heartbeat_hz=0.7, counters_period_s=3.3)


@pytest.mark.parametrize("clock", [ClockSource.LOCAL, ClockSource.PEERS])
def test_a_step_in_parts_does_what_handle_does(clock: ClockSource) -> None:
    """``begin``, ``receive`` a datagram at a time, ``tick``: the same datagrams out, the same
    records, the same counters as ``handle`` (signed links: the signing clocks too)."""
    signing = codec.SigningConfig(KEY, link_id=1)
    pairs = [GcsPair(config=_off_cycle(clock), signing=signing) for _ in range(2)]
    pairs[1].in_parts = True
    whole, in_parts = (_scripted(pair) for pair in pairs)
    assert whole == in_parts and sum(len(sent) for _, sent, _ in whole) >= 100
    timed = {"compute_ms", "pipeline_ms"}  # wall clock
    records = [
        [(topic, t_s, {k: v for k, v in r.items() if k not in timed}) for topic, t_s, r in recs]
        for recs in (pairs[0].sink.records, pairs[1].sink.records)
    ]
    assert records[0] == records[1] and len(records[0]) > 40
    assert counters(pairs[0]) == counters(pairs[1])


@pytest.mark.parametrize("clock", [ClockSource.LOCAL, ClockSource.PEERS])
def test_a_quiet_step_sends_and_logs_nothing_whatever_it_receives(clock: ClockSource) -> None:
    """What a runner relies on to answer for a step before running it (``lockstep_split``)."""
    steps = _scripted(GcsPair(config=_off_cycle(clock)))
    quiet = [(sent, logged) for is_quiet, sent, logged in steps if is_quiet]
    assert 100 < len(quiet) < len(steps)  # most steps: not the cycles, heartbeats, counters
    assert all(sent == [] and logged == 0 for sent, logged in quiet)
    assert any(logged for _, _, logged in steps)
    assert not steps[0][0]  # before its first step the GCS has no counters' schedule yet
