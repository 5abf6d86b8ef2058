r"""The GCS core, sans I/O: ``handle(now_s, inbound) -> outbound``.

One UDP port that every companion talks to, like a real ground station on 14550. Inbound
endpoint names are ``"companions@<peer>"``, ``<peer>`` an opaque sender key (``host:port``
over UDP, ``c3`` in an in-process router). Per peer the GCS keeps one shell endpoint (its link:
the parser state), learns the MAVLink system ids that speak through it, and treats it as live
while it is heard within ``peer_timeout_s``. With signing, every peer link checks against one
anti-replay window (``self.replay``, per signing stream, never per address), so packets
captured and re-sent from a new socket are refused. A system id moves to a new peer only once
its old peer has been silent for ``peer_timeout_s`` (``sysid_moves_refused`` counts the
rest): while a companion speaks, nothing another address sends moves its regions away.

Each call:

1. parse every datagram on its peer's link; observation reports go to :class:`Ingest`;
2. drop peers not heard for ``peer_timeout_s`` from the send list (they return when heard);
3. close the transmissions whose ``group_window_s`` is over (at every step: a claim is built
   as soon as it is complete, not in the cycle that takes it);
4. every ``cycle_s`` of sim time: ``pipeline.step`` on the claims closed since, log the cycle
   (``/gcs/cycle`` with the compute time, ``/gcs/detector_stats`` one record per claim with
   every detector's verdict, ``/gcs/alerts``, ``/gcs/tracks``, ``/gcs/unsafe_regions``) and
   send alerts and regions to every live peer;
5. a GCS HEARTBEAT (MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID) at ``heartbeat_hz``; ``/app/counters``
   every ``counters_period_s`` and from :meth:`Gcs.finish`.

Regions go out in the companions' frames (``outputs.region_message``); a region is valid until
``min(region.valid_until_s, now + region_validity_s)``; a deleted track's last region is sent
once more with ``RegionFlags.DELETED``. Alerts are sent when they change, and raised ones
again every ``alert_repeat_s`` (with their decision time) so late joiners learn them.

Nothing here raises on input: bad bytes, bad reports, unknown endpoints, too many peers and a
failing pipeline step are counted, logged (warnings rate-limited) and survived.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import ClassVar

from ridsafe.common import messages as m
from ridsafe.common import topics
from ridsafe.common.codec import (
    LinkCounters,
    MavlinkLink,
    Received,
    ReplayWindow,
    SigningConfig,
    warm_up_columnar,
)
from ridsafe.common.frames import GeodeticOrigin
from ridsafe.common.logsink import LogSink
from ridsafe.common.shell import (
    AppShell,
    Datagrams,
    Endpoint,
    link_counter_values,
    not_from_systems,
)
from ridsafe.gcs.config import GCS_COMPONENT_ID, GCS_SYSTEM_ID, ClockSource, GcsConfig
from ridsafe.gcs.ingest import (
    Ingest,
    RateLimitedLog,
    RejectReason,
    check_values,
    claim_order,
    plain_rows,
)
from ridsafe.gcs.outputs import (
    alert_message,
    alert_record,
    region_is_finite,
    region_message,
    region_record,
    track_record,
    verdicts_record,
)
from ridsafe.gcs.pipeline_api import (
    AlertChange,
    CycleOutput,
    GcsPipeline,
    ObservedClaim,
)

logger = logging.getLogger(__name__)

COMPANIONS_ENDPOINT = "companions"
_EPS_S = 1e-9


def peer_endpoint(peer: str) -> str:
    """The endpoint name of one companion peer: ``companions@<peer>``."""
    return f"{COMPANIONS_ENDPOINT}@{peer}"


# --- state -----------------------------------------------------------------------------------


@dataclass
class _Peer:
    key: str
    endpoint: Endpoint  # the shell's: link, outbox
    sysids: set[int] = field(default_factory=set)
    last_heard_s: float | None = None  # runner time of the last accepted packet
    live: bool = False


@dataclass
class GcsCounters:
    """What the GCS itself refused or did (the shell counts unknown endpoints, refused
    senders and datagrams; the links and ingest count their own)."""

    peers_evicted: int = 0
    sysid_moves_refused: int = 0  # a system heard through a new address while its peer lives
    peers_timed_out: int = 0
    ignored_messages: int = 0
    cycles: int = 0
    cycles_skipped: int = 0
    pipeline_errors: int = 0
    invalid_regions: int = 0
    alerts_sent: int = 0
    regions_sent: int = 0
    heartbeats_sent: int = 0


class _TimeBase:
    """GCS sim time: the runner's time (LOCAL), or the runner's time plus the offset fixed by
    the first valid report's receive time (PEERS; unknown until then)."""

    def __init__(self, source: ClockSource) -> None:
        self.source = source
        self.offset_s: float | None = 0.0 if source is ClockSource.LOCAL else None

    def sim_s(self, now_s: float) -> float | None:
        return None if self.offset_s is None else now_s + self.offset_s

    def lock(self, now_s: float, peer_t_s: float) -> None:
        self.offset_s = peer_t_s - now_s
        logger.info("sim time locked to the companions: offset %+.3f s", self.offset_s)


class Gcs:
    """The ground station core; see the module docstring."""

    def __init__(
        self,
        config: GcsConfig,
        origin: GeodeticOrigin,
        pipeline: GcsPipeline,
        sink: LogSink,
        signing: SigningConfig | None = None,
    ) -> None:
        self.config = config
        self.origin = origin
        self.pipeline = pipeline
        self.sink = sink
        self.signing = signing
        #: One anti-replay window for every peer link: signing streams are (link id, system,
        #: component), not addresses, so a stream re-sent from a new socket is still old.
        self.replay = ReplayWindow()
        self.ingest = Ingest(config, origin)
        self._ensure_reports_warm(config)
        self.counters = GcsCounters()
        self.shell = AppShell("gcs", open_endpoint=self._open_peer)
        self._peers: dict[str, _Peer] = {}  # by endpoint name, peer_endpoint(key)
        self._sysid_peer: dict[int, str] = {}
        self._time = _TimeBase(config.clock)
        self._next_cycle: int | None = 0 if config.clock is ClockSource.LOCAL else None
        self._next_heartbeat_s = 0.0
        self._next_counters_s: float | None = None
        self._raised: dict[tuple[str, m.RidsafeDetector], tuple[float, AlertChange]] = {}
        self._next_alert_repeat_s = 0.0
        self._last_region: dict[str, m.UnsafeRegionMsg] = {}
        self._accepted_at_cycle = 0
        #: Transmissions closed since the last cycle (``_close_due``), for the next one.
        self._closed: list[ObservedClaim] = []
        self._warn = RateLimitedLog(logger, config.warn_interval_s)

    _reports_warm: ClassVar[bool] = False

    @classmethod
    def _ensure_reports_warm(cls, config: GcsConfig) -> None:
        """Load the kernels a companion's batch of reports goes through (the peer links'
        columnar decoding, ``ingest.plain_rows``) once per process, before a run needs them."""
        if not cls._reports_warm:
            plain_rows(warm_up_columnar(), 0.0, config)
            cls._reports_warm = True

    # -- queries ------------------------------------------------------------------------------

    @property
    def live_peers(self) -> tuple[str, ...]:
        return tuple(p.key for p in self._peers.values() if p.live)

    @property
    def sysid_peers(self) -> dict[int, str]:
        """Which peer key each companion system id was last heard through."""
        return dict(self._sysid_peer)

    def sim_time_s(self, now_s: float) -> float | None:
        """GCS sim time at runner time ``now_s`` (None until locked, PEERS clock)."""
        return self._time.sim_s(now_s)

    def link_counters(self) -> LinkCounters:
        """Every peer link's counters summed (peers evicted since included)."""
        return self.shell.link_totals()

    def counter_values(self) -> dict[str, int]:
        links = link_counter_values(self.link_counters())
        out = {f"link_{name}": value for name, value in links.items()}
        out.update(self.ingest.counters.as_dict())
        out.update(self.shell.counters.as_dict())
        out.update(self.shell.edge_counters())
        out.update(dataclasses.asdict(self.counters))
        out["replayed"] = self.replay.replayed  # of link_rejected_signature: old stamps
        out["stale_new_stream"] = self.replay.stale_new_stream
        out["peers_known"] = len(self._peers)
        out["peers_live"] = len(self.live_peers)
        return out

    # -- the sans-I/O step --------------------------------------------------------------------

    def handle(self, now_s: float, inbound: Iterable[tuple[str, bytes]]) -> Datagrams:
        """Consume inbound datagrams, run what is due at ``now_s``, return outbound datagrams:
        :meth:`begin`, :meth:`receive`, :meth:`tick`, which a runner may also call one by one
        (``receive`` any number of times between the other two), to the same effect."""
        self.begin(now_s)
        self.receive(now_s, inbound)
        return self.tick(now_s)

    def begin(self, now_s: float) -> None:
        """The start of the step at ``now_s``: the links' signing clocks follow it."""
        self.shell.advance_signing_clocks(now_s)

    def receive(self, now_s: float, inbound: Iterable[tuple[str, bytes]]) -> None:
        """Consume inbound datagrams of the step at ``now_s``: sends and logs nothing."""
        self.shell.dispatch(
            inbound, lambda endpoint, received: self._accept(now_s, endpoint.name, received)
        )

    def quiet_at(self, now_s: float) -> bool:
        """True when the step at ``now_s`` can send nothing and log nothing, whatever it
        receives: the sim clock known, the counters' schedule started, and no cycle,
        heartbeat or counters due. A runner may then answer for the step before it runs it.
        What this reads changes only in steps that are not quiet (the one that locks a PEERS
        clock, the first with a clock, the due ones), so it holds as well for a step whose
        earlier quiet steps have not run yet."""
        sim_now = self._time.sim_s(now_s)
        if sim_now is None or self._next_counters_s is None:
            return False
        return not (
            self._counters_due(sim_now) or self._cycle_due(sim_now) or self._heartbeat_due(now_s)
        )

    def _cycle_due(self, sim_now: float) -> bool:
        index = self._next_cycle
        return index is not None and sim_now >= index * self.config.cycle_s - _EPS_S

    def _counters_due(self, sim_now: float) -> bool:
        due_s = self._next_counters_s
        return due_s is not None and sim_now >= due_s - _EPS_S

    def _heartbeat_due(self, now_s: float) -> bool:
        return now_s >= self._next_heartbeat_s - _EPS_S

    def tick(self, now_s: float) -> Datagrams:
        """The rest of the step at ``now_s`` (after :meth:`receive`): peers, cycle, counters,
        heartbeat; returns outbound datagrams."""
        self._expire_peers(now_s)
        sim_now = self._time.sim_s(now_s)
        if sim_now is not None:
            self._close_due(sim_now)
            self._maybe_cycle(sim_now)
            self._maybe_log_counters(sim_now)
        if self._heartbeat_due(now_s):
            self._next_heartbeat_s = now_s + 1.0 / self.config.heartbeat_hz
            heartbeat = m.Heartbeat(
                int(m.MavType.GCS), int(m.MavAutopilot.INVALID), 0, 0, int(m.MavState.ACTIVE)
            )
            self._broadcast([heartbeat])
            self.counters.heartbeats_sent += len(self.live_peers)
        return self.shell.flush()

    def finish(self, now_s: float) -> None:
        """Log the final ``/app/counters`` (call once when the run ends)."""
        sim_now = self._time.sim_s(now_s)
        self._log_counters(now_s if sim_now is None else sim_now)

    # -- inbound ------------------------------------------------------------------------------

    def _open_peer(self, name: str) -> Endpoint | str | None:
        """The shell asks for an endpoint it does not have: a new companion peer (None: not
        a peer's name; "peer_limit": ``max_peers`` peers, none dead to make room)."""
        base, sep, key = name.partition("@")
        if base != COMPANIONS_ENDPOINT or not sep or not key:
            return None
        if len(self._peers) >= self.config.max_peers and not self._evict_dead_peer():
            return "peer_limit"
        link = MavlinkLink(
            GCS_SYSTEM_ID, GCS_COMPONENT_ID, self.signing, self.replay, columnar=True
        )
        endpoint = Endpoint(name, link, accept=not_from_systems((0, GCS_SYSTEM_ID)))
        self._peers[name] = _Peer(key, endpoint)
        return endpoint

    def _evict_dead_peer(self) -> bool:
        dead = [p for p in self._peers.values() if not p.live]
        if not dead:
            return False
        victim = min(dead, key=lambda p: -math.inf if p.last_heard_s is None else p.last_heard_s)
        del self._peers[victim.endpoint.name]
        self.shell.remove(victim.endpoint.name)
        for sysid in victim.sysids:
            if self._sysid_peer.get(sysid) == victim.key:
                del self._sysid_peer[sysid]
        self.counters.peers_evicted += 1
        return True

    def _accept(self, now_s: float, endpoint: str, received: Received) -> None:
        peer = self._peers[endpoint]
        sysid = received.src_system  # not 0 nor ours: the endpoint's sender check
        self._heard(now_s, peer, sysid)
        message = received.message
        if type(message) is m.ObservationRows:
            self._observe_rows(now_s, sysid, message)
        elif isinstance(message, m.Observation):
            self._observe(now_s, sysid, message)
        elif not isinstance(message, m.Heartbeat):
            self.counters.ignored_messages += m.messages_in(message)

    def _heard(self, now_s: float, peer: _Peer, sysid: int) -> None:
        peer.last_heard_s = now_s
        if not peer.live:
            peer.live = True
            logger.info("companion peer %s (system %d) is live", peer.key, sysid)
        previous = self._sysid_peer.get(sysid)
        if previous == peer.key:
            return
        old = self._peers.get(peer_endpoint(previous)) if previous is not None else None
        if old is not None and self._still_speaks(old, now_s):
            self.counters.sysid_moves_refused += 1  # stays with the peer that still speaks
            return
        self._sysid_peer[sysid] = peer.key
        peer.sysids.add(sysid)
        if old is not None:
            old.sysids.discard(sysid)
            logger.info("system %d moved from peer %s to %s", sysid, old.key, peer.key)
            if not old.sysids and old.live:
                old.live = False
                logger.info("peer %s has no systems left: no longer sent to", old.key)

    def _still_speaks(self, peer: _Peer, now_s: float) -> bool:
        heard = peer.last_heard_s
        return peer.live and heard is not None and now_s - heard <= self.config.peer_timeout_s

    def _observe(self, now_s: float, rx_sysid: int, obs: m.Observation) -> None:
        if self._time.offset_s is None and check_values(obs, self.config) is None:
            self._time.lock(now_s, obs.t_s)
            self._next_cycle = math.ceil(obs.t_s / self.config.cycle_s - _EPS_S)
        sim_now = self._time.sim_s(now_s)
        reason = self.ingest.add(obs.t_s if sim_now is None else sim_now, rx_sysid, obs)
        if reason is not None:
            self._warn_rejected(now_s, rx_sysid, obs.uas_id, reason)

    def _observe_rows(self, now_s: float, rx_sysid: int, rows: m.ObservationRows) -> None:
        """``_observe`` of every row, in order; with the clock locked, the rows at once."""
        sim_now = self._time.sim_s(now_s)
        if sim_now is None:  # the first valid report locks the clock
            for i in range(len(rows)):
                self._observe(now_s, rx_sysid, rows.observation(i))
            return
        for uas_id, reason in self.ingest.add_rows(sim_now, rx_sysid, rows):
            self._warn_rejected(now_s, rx_sysid, uas_id, reason)

    def _warn_rejected(
        self, now_s: float, rx_sysid: int, uas_id: str, reason: RejectReason
    ) -> None:
        self._warn.warn(
            now_s,
            f"reject/{reason.value}",
            f"report from system {rx_sysid} about {uas_id!r} rejected: {reason.value}",
        )

    def _expire_peers(self, now_s: float) -> None:
        for peer in self._peers.values():
            if not peer.live or peer.last_heard_s is None:
                continue
            if now_s - peer.last_heard_s > self.config.peer_timeout_s:
                peer.live = False
                self.counters.peers_timed_out += 1
                logger.warning(
                    "companion peer %s (systems %s) not heard for %.1f s: no longer sent to",
                    peer.key,
                    sorted(peer.sysids),
                    now_s - peer.last_heard_s,
                )

    # -- the cycle ----------------------------------------------------------------------------

    def _maybe_cycle(self, sim_now: float) -> None:
        index = self._next_cycle
        if index is None or not self._cycle_due(sim_now):
            return
        current = math.floor(sim_now / self.config.cycle_s + _EPS_S)
        self.counters.cycles_skipped += max(0, current - index)
        self._next_cycle = current + 1
        self._cycle(sim_now)

    def _close_due(self, sim_now: float) -> None:
        """Close the transmissions whose ``group_window_s`` is over, at every step: a claim
        is built as soon as it is complete, between the cycles, and the next cycle takes it."""
        self._closed.extend(self.ingest.close_due(sim_now))

    def _cycle(self, now_s: float) -> None:
        start = time.perf_counter()  # compute time only, never sim time
        closed, self._closed = self._closed, []
        closed.sort(key=claim_order)  # several steps' closings, in one order
        output, error = self._step_pipeline(now_s, closed)
        pipeline_ms = (time.perf_counter() - start) * 1e3
        messages: list[m.Message] = self._alert_messages(now_s, output)
        regions = self._region_messages(now_s, output)
        messages.extend(regions)
        self._broadcast(messages)
        compute_ms = (time.perf_counter() - start) * 1e3
        self.counters.cycles += 1
        accepted = self.ingest.counters.accepted
        self.sink.log(
            topics.GCS_CYCLE,
            now_s,
            {
                "compute_ms": compute_ms,
                "pipeline_ms": pipeline_ms,
                "n_observations": accepted - self._accepted_at_cycle,
                "n_transmissions": len(closed),
                "n_tracks": len(output.tracks),
                "n_regions": len(output.regions),
                "n_alerts_raised": len(self._raised),
                "n_peers_live": len(self.live_peers),
                "open_groups": self.ingest.open_groups,
                "deleted_tracks": list(output.deleted_tracks),
                "error": error,
            },
        )
        self._accepted_at_cycle = accepted
        self._log_output(now_s, output, regions)

    def _step_pipeline(
        self, now_s: float, closed: list[ObservedClaim]
    ) -> tuple[CycleOutput, str | None]:
        try:
            return self.pipeline.step(now_s, closed), None
        except Exception as exc:  # a pipeline bug must not take the GCS down: count, log
            self.counters.pipeline_errors += 1
            error = f"{type(exc).__name__}: {exc}"
            if self.counters.pipeline_errors == 1:  # the first with its traceback
                logger.exception("pipeline step at t=%.2f s failed (counted, continuing)", now_s)
            else:
                self._warn.warn(now_s, "pipeline", f"pipeline step at t={now_s:.2f} s: {error}")
            return CycleOutput(), error

    def _alert_messages(self, now_s: float, output: CycleOutput) -> list[m.Message]:
        changed: set[tuple[str, m.RidsafeDetector]] = set()
        messages: list[m.Message] = []
        for change in output.alert_changes:
            key = (change.uas_id, change.detector)
            changed.add(key)
            if change.state is m.AlertState.RAISED:
                self._raised[key] = (now_s, change)
            else:
                self._raised.pop(key, None)
            messages.append(alert_message(now_s, change))
        if now_s >= self._next_alert_repeat_s - _EPS_S:
            self._next_alert_repeat_s = now_s + self.config.alert_repeat_s
            repeats = [(t, c) for k, (t, c) in self._raised.items() if k not in changed]
            messages.extend(alert_message(t, c) for t, c in repeats)
        self.counters.alerts_sent += len(messages)
        return messages

    def _region_messages(self, now_s: float, output: CycleOutput) -> list[m.UnsafeRegionMsg]:
        coasting = {t.track_id for t in output.tracks if not t.fix}
        messages: list[m.UnsafeRegionMsg] = []
        for region in output.regions:
            if not region_is_finite(region):
                self.counters.invalid_regions += 1
                message = f"non-finite region for {region.uas_id!r} not sent"
                self._warn.warn(now_s, "region", message)
                continue
            flags = m.RegionFlags.COASTING if region.track_id in coasting else m.RegionFlags.NONE
            if region.on_ground:
                flags |= m.RegionFlags.ON_GROUND
            if region.unconfirmed:
                flags |= m.RegionFlags.UNCONFIRMED
            msg = region_message(
                self.origin, region, now_s, self.config.region_validity_s, int(flags)
            )
            self._last_region[region.uas_id] = msg
            messages.append(msg)
        for uas_id in output.deleted_tracks:
            last = self._last_region.pop(uas_id, None)
            if last is not None:
                deleted = int(m.RegionFlags.DELETED)
                messages.append(dataclasses.replace(last, valid_until_s=now_s, flags=deleted))
        self.counters.regions_sent += len(messages)
        return messages

    # -- logging ------------------------------------------------------------------------------

    def _log_output(self, now_s: float, output: CycleOutput, sent: list[m.UnsafeRegionMsg]) -> None:
        for results in output.claim_results:
            if results:
                self.sink.log(topics.DETECTOR_STATS, now_s, verdicts_record(results))
        if output.channel is not None:
            self.sink.log(topics.GCS_CHANNEL, now_s, dataclasses.asdict(output.channel))
        for change in output.alert_changes:
            self.sink.log(topics.ALERTS, now_s, alert_record(change))
        for track in output.tracks:
            self.sink.log(topics.TRACKS, now_s, track_record(track))
        by_track = {(s.uas_id, s.track_id): s for s in sent if not s.flags & m.RegionFlags.DELETED}
        for region in output.regions:
            msg = by_track.get((region.uas_id, region.track_id))
            if msg is not None:
                self.sink.log(topics.REGIONS, now_s, region_record(region, msg))

    def _maybe_log_counters(self, sim_now: float) -> None:
        if self._next_counters_s is None:
            self._next_counters_s = sim_now + self.config.counters_period_s
        elif self._counters_due(sim_now):
            self._next_counters_s = sim_now + self.config.counters_period_s
            self._log_counters(sim_now)

    def _log_counters(self, t_s: float) -> None:
        self.sink.log(topics.APP_COUNTERS, t_s, {"app": "gcs", "counters": self.counter_values()})

    # -- outbound -----------------------------------------------------------------------------

    def _broadcast(self, messages: list[m.Message]) -> None:
        live = [name for name, peer in self._peers.items() if peer.live]
        self.shell.broadcast(live, messages)
