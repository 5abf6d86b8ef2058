"""The companion computer of one aircraft, sans I/O: ``handle(now_s, inbound) -> outbound``.

Endpoints: ``"autopilot"`` (MAVLink to the flight controller and, on the same link, the RID
transponder, component 236) and ``"gcs"`` (observations up, unsafe regions and alerts down;
MAVLink 2 signing when a key is configured). Identity: the vehicle's system id, component 191
(MAV_COMP_ID_ONBOARD_COMPUTER), HEARTBEAT type 18 at ``heartbeat_hz`` on both links. Only
common.xml messages go to the autopilot; the transponder's RIDSAFE_RID_RSSI is read through
the ``RssiSource`` interface only.

Each call, in order:

1. parse what came in: the autopilot's HEARTBEAT (component 1 only), GLOBAL_POSITION_INT,
   LOCAL_POSITION_NED, HOME_POSITION, SYSTEM_TIME, COMMAND_ACK, STATUSTEXT; the transponder's
   messages go to the RSSI source; the GCS's regions and alerts to the region store;
2. watch the links (autopilot heartbeat lost / back; GCS seen / lost);
3. step the mission (``mission.Mission``): commands to send;
4. own Remote ID (``rid.OwnRidBroadcaster``) to the transponder;
5. heard broadcasts -> neighbours and observations; a due batch goes to the GCS;
6. in CRUISE, every ``replan_period_s``: plan and send SET_POSITION_TARGET_LOCAL_NED
   (position + velocity, type_mask 3520; position only, 3576, when the velocity is zero);
   in HOVER, hold the goal;
7. heartbeats and the ``/app/counters`` record every ``counters_period_s``.

Frames: the autopilot's local NED frame (LOCAL_POSITION_NED, setpoints, the planner) is the
tangent frame at home shifted so that home sits at HOME_POSITION's (x, y, z) (ArduPilot's EKF
origin may differ from home; the sim's is home itself)::

    p_local = geodetic_to_ned(home, lat, lon, alt) + home_local

Clocks: ``now_s`` is this core's clock. Times that leave the companion (observation and
neighbour times, planner input, region expiry, log records) are on the autopilot's clock,
estimated as ``now_s + offset`` with offset = max over telemetry of (time_boot - arrival); in
the sim that is sim time, shared by every vehicle, the GCS and the truth log.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, fields

from ridsafe.common import codec, frames, topics
from ridsafe.common import messages as m
from ridsafe.common.errors import ClockError
from ridsafe.common.logsink import LogSink
from ridsafe.companion.config import (
    AUTOPILOT_COMPONENT,
    COMPANION_COMPONENT,
    TRANSPONDER_COMPONENT,
    CompanionConfig,
    CompanionSpec,
)
from ridsafe.companion.mission import FlightStatus, Mission, MissionEvent, Phase
from ridsafe.companion.neighbours import NeighbourTable
from ridsafe.companion.observations import (
    ObservationBatcher,
    OwnTelemetry,
    RssiSource,
    SimTransponderRssi,
    batch_record,
)
from ridsafe.companion.planner_api import (
    Planner,
    PlannerDecision,
    PlannerInput,
    PlannerStatus,
    Vec3,
)
from ridsafe.companion.regions import RegionStore
from ridsafe.companion.rid import OperatorLocation, OwnRidBroadcaster, Periodic

__all__ = ["AUTOPILOT", "GCS", "Companion", "CompanionCounters"]

logger = logging.getLogger(__name__)

AUTOPILOT = "autopilot"
GCS = "gcs"
MAX_DATAGRAM_BYTES = 1400
_ZERO: Vec3 = (0.0, 0.0, 0.0)
_QUIET_REGION_OUTCOMES = frozenset({"replaced", "stale"})
_CRITICAL_STATES = frozenset({int(m.MavState.CRITICAL), int(m.MavState.EMERGENCY)})

Datagrams = list[tuple[str, bytes]]
# HEARTBEAT of an onboard computer (MAV_TYPE_ONBOARD_CONTROLLER, MAV_AUTOPILOT_INVALID)
_OWN_HEARTBEAT = m.Heartbeat(
    int(m.MavType.ONBOARD_CONTROLLER), int(m.MavAutopilot.INVALID), 0, 0, int(m.MavState.ACTIVE)
)


@dataclass
class CompanionCounters:
    datagrams_in: int = 0
    datagrams_out: int = 0
    unknown_endpoint: int = 0
    foreign_system: int = 0  # autopilot-link messages from another system id
    other_component: int = 0
    unused_autopilot: int = 0  # decoded but not for us (e.g. GCS messages on this link)
    unused_gcs: int = 0
    acks_unmatched: int = 0
    autopilot_lost: int = 0
    decisions: int = 0
    planner_errors: int = 0
    plan_skipped: int = 0  # replan slots with no position or no home yet
    setpoints: int = 0


Handler = Callable[["Companion", float, m.Message], None]


class Companion:
    """One aircraft's companion computer; see the module docstring."""

    def __init__(
        self,
        spec: CompanionSpec,
        config: CompanionConfig,
        planner: Planner,
        sink: LogSink,
        signing: codec.SigningConfig | None = None,
        rssi_source: RssiSource | None = None,
    ) -> None:
        self.spec = spec
        self.config = config
        self.planner = planner
        self.sink = sink
        self.links = {
            AUTOPILOT: codec.MavlinkLink(spec.sysid, COMPANION_COMPONENT),
            GCS: codec.MavlinkLink(spec.sysid, COMPANION_COMPONENT, signing),
        }
        self.own = OwnTelemetry()
        self.mission = Mission(config, spec.sysid, AUTOPILOT_COMPONENT)
        self.rid = OwnRidBroadcaster(spec.serial, spec.operator_id, config)
        self.rssi = rssi_source or SimTransponderRssi(config.rssi_pair_timeout_s)
        self.batcher = ObservationBatcher(config.observation_batch_s)
        self.regions = RegionStore()
        self.neighbours = NeighbourTable(spec.serial, config.neighbour_max_age_s)
        self.counters = CompanionCounters()
        self.last_decision: PlannerDecision | None = None
        self.t_s = -math.inf
        self.gcs_seen_s: float | None = None
        self.transponder_arm_status: m.OdidArmStatus | None = None
        self._autopilot_lost = False
        self._gcs_lost = False
        self._heartbeat = Periodic(1.0 / config.heartbeat_hz)
        self._replan = Periodic(config.replan_period_s)
        self._counters = Periodic(config.counters_period_s, config.counters_period_s)
        self._goal_cache: tuple[frames.GeodeticOrigin, Vec3, Vec3] | None = None
        self._out: dict[str, list[bytes]] = {AUTOPILOT: [], GCS: []}

    # -- the sans-I/O step ------------------------------------------------------------------

    def handle(self, now_s: float, inbound: Datagrams) -> Datagrams:
        """Consume inbound datagrams, act for ``now_s``, return outbound datagrams."""
        if not math.isfinite(now_s) or now_s < self.t_s:
            raise ClockError(f"companion time must not go backwards: {self.t_s} -> {now_s}")
        self.t_s = now_s
        for endpoint, data in inbound:
            self._receive(now_s, endpoint, data)
        self._watch_links(now_s)
        self._step_mission(now_s)
        self._broadcast_rid(now_s)
        self._observe(now_s)
        self._setpoint(now_s)
        self._periodic(now_s)
        return self._flush()

    def finish(self, now_s: float) -> Datagrams:
        """At the end of a run: send what is still batched and log the counters."""
        self._send_observations(now_s, self.batcher.take_all())
        self._log_counters(now_s)
        return self._flush()

    @property
    def phase(self) -> Phase:
        return self.mission.phase

    def sim_time(self, now_s: float) -> float:
        return self.own.sim_time(now_s)

    # -- inbound ---------------------------------------------------------------------------

    def _receive(self, now_s: float, endpoint: str, data: bytes) -> None:
        link = self.links.get(endpoint)
        if link is None:
            self.counters.unknown_endpoint += 1
            level = logging.WARNING if self.counters.unknown_endpoint == 1 else logging.DEBUG
            logger.log(
                level,
                "companion %d: datagram on unknown endpoint %r (counted)",
                self.spec.sysid,
                endpoint,
            )
            return
        self.counters.datagrams_in += 1
        for received in link.feed(data):
            if endpoint == AUTOPILOT:
                self._from_autopilot(now_s, received)
            else:
                self._from_gcs(now_s, received)

    def _from_autopilot(self, now_s: float, received: codec.Received) -> None:
        if received.src_system != self.spec.sysid:
            self.counters.foreign_system += 1
            return
        if received.src_component == TRANSPONDER_COMPONENT:
            self._from_transponder(now_s, received.message)
            return
        if received.src_component != AUTOPILOT_COMPONENT:
            self.counters.other_component += 1
            return
        handler = _AUTOPILOT_HANDLERS.get(type(received.message))
        if handler is None:
            self.counters.unused_autopilot += 1
            return
        handler(self, now_s, received.message)

    def _on_heartbeat(self, now_s: float, msg: m.Message) -> None:
        assert isinstance(msg, m.Heartbeat)
        previous = self.own.heartbeat
        self.own.heartbeat, self.own.heartbeat_s = msg, now_s
        if previous is None:
            self._event(now_s, "autopilot_seen", f"mode {_mode_name(msg.custom_mode)}")
        elif (previous.custom_mode, previous.armed) != (msg.custom_mode, msg.armed):
            state = "armed" if msg.armed else "disarmed"
            self._event(now_s, "autopilot_state", f"{_mode_name(msg.custom_mode)}, {state}")
        if self._autopilot_lost:
            self._autopilot_lost = False
            self._event(now_s, "autopilot_regained", "heartbeat is back")

    def _on_gpi(self, now_s: float, msg: m.Message) -> None:
        assert isinstance(msg, m.GlobalPositionInt)
        self.own.gpi, self.own.gpi_s = msg, now_s
        self.own.observe_clock(now_s, msg.time_boot_s)

    def _on_lpn(self, now_s: float, msg: m.Message) -> None:
        assert isinstance(msg, m.LocalPositionNed)
        self.own.lpn = msg
        self.own.observe_clock(now_s, msg.time_boot_s)

    def _on_home(self, now_s: float, msg: m.Message) -> None:
        assert isinstance(msg, m.HomePosition)
        if self.own.home is None:
            self._event(
                now_s, "home", f"{msg.lat_deg:.7f}, {msg.lon_deg:.7f}, {msg.alt_msl_m:.1f} m"
            )
        self.own.set_home(msg)

    def _on_system_time(self, now_s: float, msg: m.Message) -> None:
        assert isinstance(msg, m.SystemTime)
        self.own.system_time, self.own.system_time_s = msg, now_s
        self.own.observe_clock(now_s, msg.time_boot_s)

    def _on_ack(self, now_s: float, msg: m.Message) -> None:
        assert isinstance(msg, m.CommandAck)
        system_ok = msg.target_system in (0, self.spec.sysid)
        for_us = system_ok and msg.target_component in (0, COMPANION_COMPONENT)
        if not (for_us and self.mission.on_ack(now_s, msg)):
            self.counters.acks_unmatched += 1
        self._log_mission_events(now_s)

    def _on_status_text(self, now_s: float, msg: m.Message) -> None:
        assert isinstance(msg, m.StatusText)
        self._event(now_s, "autopilot_text", msg.text, severity=msg.severity)

    def _from_transponder(self, now_s: float, msg: m.Message) -> None:
        if isinstance(msg, m.OdidArmStatus):
            previous = self.transponder_arm_status
            if previous is None or previous.status != msg.status:
                detail = "ready" if msg.status == 0 else f"not ready: {msg.error}"
                self._event(now_s, "rid_arm_status", detail, status=msg.status)
            self.transponder_arm_status = msg
        elif not isinstance(msg, m.Heartbeat | m.CommandAck):
            self.rssi.on_mavlink(now_s, msg)

    def _from_gcs(self, now_s: float, received: codec.Received) -> None:
        if self.gcs_seen_s is None or self._gcs_lost:
            self._event(now_s, "gcs_seen", f"system {received.src_system}")
            self._gcs_lost = False
        self.gcs_seen_s = now_s
        msg = received.message
        sim_now = self.sim_time(now_s)
        if isinstance(msg, m.UnsafeRegionMsg):
            outcome = self.regions.on_region(sim_now, msg)
            if outcome not in _QUIET_REGION_OUTCOMES:
                self._event(now_s, "region", f"{msg.uas_id}: {outcome}", uas_id=msg.uas_id)
        elif isinstance(msg, m.SpoofAlert):
            if self.regions.on_alert(msg):
                state = "raised" if self.regions.is_flagged(msg.uas_id) else "cleared"
                self._event(now_s, "alert", f"{msg.uas_id}: {state}", uas_id=msg.uas_id)
        elif not isinstance(msg, m.Heartbeat):
            self.counters.unused_gcs += 1

    # -- links and mission -----------------------------------------------------------------

    def _link_up(self, now_s: float) -> bool:
        beat = self.own.heartbeat_s
        return beat is not None and now_s - beat <= self.config.autopilot_timeout_s

    def _watch_links(self, now_s: float) -> None:
        if (
            self.own.heartbeat_s is not None
            and not self._link_up(now_s)
            and not self._autopilot_lost
        ):
            self._autopilot_lost = True
            self.counters.autopilot_lost += 1
            silent = now_s - self.own.heartbeat_s
            self._event(now_s, "autopilot_lost", f"no heartbeat for {silent:.1f} s")
        gcs = self.gcs_seen_s
        if gcs is not None and not self._gcs_lost and now_s - gcs > self.config.gcs_timeout_s:
            self._gcs_lost = True
            self._event(now_s, "gcs_lost", f"nothing from the GCS for {now_s - gcs:.1f} s")
        for uas_id in self.regions.expire(self.sim_time(now_s)):
            self._event(now_s, "region", f"{uas_id}: expired", uas_id=uas_id)

    def _goal_local(self) -> Vec3 | None:
        """The delivery point in the local frame: at cruise altitude, or on the ground (home
        level) once the aircraft descends to deliver."""
        origin, home = self.own.home_origin, self.own.home
        if origin is None or home is None:
            return None
        if self._goal_cache is None or self._goal_cache[0] != origin:
            lat, lon = self.spec.goal_lat_deg, self.spec.goal_lon_deg
            cruise = self.own.to_local(lat, lon, home.alt_msl_m + self.spec.cruise_alt_m)
            ground = self.own.to_local(lat, lon, home.alt_msl_m)
            self._goal_cache = (origin, cruise, ground)
        _, cruise, ground = self._goal_cache
        return ground if self.mission.phase is Phase.DESCEND else cruise

    def _flight_status(self, now_s: float) -> FlightStatus:
        gpi, lpn, goal = self.own.gpi, self.own.lpn, self._goal_local()
        distance = alt_error = speed = None
        if lpn is not None:
            speed = math.hypot(*lpn.v_ned_m_s)
            if goal is not None:
                p = lpn.p_ned_m
                distance = math.hypot(goal[0] - p[0], goal[1] - p[1])
                alt_error = abs(goal[2] - p[2])
        return FlightStatus(
            link_up=self._link_up(now_s),
            departure_due=self.sim_time(now_s) >= self.spec.departure_s,
            heartbeat_s=self.own.heartbeat_s,
            armed=self.own.armed,
            altitude_m=None if gpi is None else gpi.relative_alt_m,
            goal_distance_h_m=distance,
            goal_alt_error_m=alt_error,
            speed_m_s=speed,
        )

    def _step_mission(self, now_s: float) -> None:
        for command in self.mission.step(now_s, self._flight_status(now_s)):
            self._send(AUTOPILOT, command)
        self._log_mission_events(now_s)

    def _log_mission_events(self, now_s: float) -> None:
        for event in self.mission.take_events():
            self._mission_event(now_s, event)

    def _mission_event(self, now_s: float, event: MissionEvent) -> None:
        self._event(now_s, event.event, event.detail, **event.fields)
        if event.event == "phase" and event.fields.get("to") == Phase.ARRIVED.value:
            self._event(now_s, "arrived", f"within {self.config.arrival_radius_m:g} m of the goal")

    def emergency(self) -> bool:
        """Remote ID EMERGENCY: the mission failed in the air, the autopilot reports a
        critical state, or it went silent while armed."""
        heartbeat = self.own.heartbeat
        critical = heartbeat is not None and heartbeat.system_status in _CRITICAL_STATES
        failed = self.mission.phase is Phase.FAILED
        return self.own.armed and (failed or critical or self._autopilot_lost)

    # -- Remote ID and observations --------------------------------------------------------

    def _broadcast_rid(self, now_s: float) -> None:
        if now_s < self.rid.next_due_s():
            return
        home = self.own.home
        operator = (
            None if home is None else OperatorLocation(home.lat_deg, home.lon_deg, home.alt_msl_m)
        )
        own = self.own.rid_state(now_s, self.emergency(), self.config.max_extrapolation_s)
        for msg in self.rid.due(now_s, own, operator, self.own.unix_s(now_s)):
            self._send(AUTOPILOT, msg)

    def _observe(self, now_s: float) -> None:
        heard_now = self.rssi.poll(now_s)
        fix = self.own.fix() if heard_now else None
        for heard in heard_now:
            rx_sim_s = self.sim_time(heard.rx_t_s)
            self.neighbours.update(rx_sim_s, heard.location)
            self.batcher.add(heard, fix, rx_sim_s, self.config.max_extrapolation_s)
        self._send_observations(now_s, self.batcher.take_due(now_s))

    def _send_observations(self, now_s: float, batch: list[m.Observation]) -> None:
        if not batch:
            return
        if self.gcs_seen_s is None:
            self.batcher.counters.sent_before_gcs_seen += len(batch)
        for observation in batch:
            self._send(GCS, observation)
        self.sink.log(
            topics.OBSERVATIONS, self.sim_time(now_s), batch_record(self.spec.sysid, batch)
        )

    # -- setpoints -------------------------------------------------------------------------

    def _setpoint(self, now_s: float) -> None:
        action = _SETPOINT_ACTIONS.get(self.mission.phase)
        if action is not None and self._replan.due(now_s):
            action(self, now_s)

    def _plan(self, now_s: float) -> None:
        lpn, goal = self.own.lpn, self._goal_local()
        if lpn is None or goal is None:
            self.counters.plan_skipped += 1
            return
        sim_now = self.sim_time(now_s)
        to_local = self.own.to_local
        planner_input = PlannerInput(
            t_s=sim_now,
            p_ned_m=lpn.p_ned_m,
            v_ned_m_s=lpn.v_ned_m_s,
            goal_ned_m=goal,
            neighbours=self.neighbours.neighbours(sim_now, to_local, self.regions.flagged),
            regions=self.regions.regions(sim_now, to_local),
        )
        start = time.perf_counter()
        decision = self._decide(now_s, planner_input)
        compute_ms = (time.perf_counter() - start) * 1e3
        self.last_decision = decision
        self.counters.decisions += 1
        self._send_target(now_s, decision.target_p_ned_m, decision.target_v_ned_m_s)
        self._log_decision(now_s, planner_input, decision, compute_ms)

    def _decide(self, now_s: float, planner_input: PlannerInput) -> PlannerDecision:
        """The planner's decision; on an exception or a non-finite target, hold position."""
        try:
            decision = self.planner.plan(planner_input)
            values = (*decision.target_p_ned_m, *decision.target_v_ned_m_s)
            if not all(math.isfinite(v) for v in values):
                raise ValueError(f"non-finite target {values}")
        except Exception as exc:  # a planner bug must not crash the aircraft's companion
            self.counters.planner_errors += 1
            logger.exception("companion %d: planner %s failed", self.spec.sysid, self.planner.name)
            self._event(now_s, "planner_error", repr(exc))
            return PlannerDecision(planner_input.p_ned_m, _ZERO, PlannerStatus.STUCK, None, "error")
        return decision

    def _hold_goal(self, now_s: float) -> None:
        goal = self._goal_local()
        if goal is not None:
            self._send_target(now_s, goal, _ZERO)

    def _send_target(self, now_s: float, p_ned_m: Vec3, v_ned_m_s: Vec3) -> None:
        mask = m.PositionTargetMask.POSITION_ONLY
        if any(v != 0.0 for v in v_ned_m_s):
            mask = m.PositionTargetMask.POSITION_VELOCITY
        self.counters.setpoints += 1
        target = m.SetPositionTargetLocalNed(
            max(0.0, self.sim_time(now_s)), self.spec.sysid, AUTOPILOT_COMPONENT,
            int(m.MavFrame.LOCAL_NED), int(mask), p_ned_m, v_ned_m_s, _ZERO, 0.0, 0.0,
        )  # fmt: skip
        self._send(AUTOPILOT, target)

    def _log_decision(
        self,
        now_s: float,
        planner_input: PlannerInput,
        decision: PlannerDecision,
        compute_ms: float,
    ) -> None:
        lat, lon, alt = self.own.to_geodetic(decision.target_p_ned_m)
        record = {
            "sysid": self.spec.sysid,
            "planner": self.planner.name,
            "status": decision.status.value,
            "target_p_ned_m": list(decision.target_p_ned_m),
            "target_v_ned_m_s": list(decision.target_v_ned_m_s),
            "target_lat_deg": lat,
            "target_lon_deg": lon,
            "target_alt_m": alt,
            "compute_ms": compute_ms,
            "n_neighbours": len(planner_input.neighbours),
            "n_regions": len(planner_input.regions),
            "p_ned_m": list(planner_input.p_ned_m),
            "value": decision.value,
            "detail": decision.detail,
        }
        self.sink.log(topics.DECISIONS, planner_input.t_s, record)

    # -- periodic, counters, output --------------------------------------------------------

    def _periodic(self, now_s: float) -> None:
        if self._heartbeat.due(now_s):
            self._send(AUTOPILOT, _OWN_HEARTBEAT)
            self._send(GCS, _OWN_HEARTBEAT)
        if self._counters.due(now_s):
            self._log_counters(now_s)

    def counters_snapshot(self) -> dict[str, int]:
        """Every counter of this companion, flat: ``"autopilot.bad_data"``, ``"rssi.paired"``."""
        out: dict[str, int] = {}
        for name, link in self.links.items():
            for f in fields(link.counters):
                value = getattr(link.counters, f.name)
                if isinstance(value, int):
                    out[f"{name}.{f.name}"] = value
        groups: dict[str, dict[str, int]] = {
            "companion": asdict(self.counters),
            "rssi": self.rssi.counters(),
            "observations": asdict(self.batcher.counters),
            "rid": asdict(self.rid.counters),
            "regions": self.regions.counters_dict(),
            "neighbours": {"unusable": self.neighbours.unusable, "live": len(self.neighbours)},
        }
        for group, values in groups.items():
            out.update({f"{group}.{k}": int(v) for k, v in values.items()})
        return out

    def _log_counters(self, now_s: float) -> None:
        record = {"app": f"companion/{self.spec.sysid}", "counters": self.counters_snapshot()}
        self.sink.log(topics.APP_COUNTERS, self.sim_time(now_s), record)

    def _event(self, now_s: float, event: str, detail: str, **extra: object) -> None:
        logger.info("companion %d: %s: %s", self.spec.sysid, event, detail)
        record = {"sysid": self.spec.sysid, "event": event, "detail": detail, **extra}
        self.sink.log(topics.COMPANION_EVENTS, self.sim_time(now_s), record)

    def _send(self, endpoint: str, msg: m.Message) -> None:
        self._out[endpoint].append(self.links[endpoint].pack(msg))

    def _flush(self) -> Datagrams:
        out: Datagrams = []
        for endpoint, packets in self._out.items():
            out.extend((endpoint, datagram) for datagram in _datagrams(packets))
            packets.clear()
        self.counters.datagrams_out += len(out)
        return out


def _mode_name(custom_mode: int) -> str:
    try:
        return m.CopterMode(custom_mode).name
    except ValueError:
        return f"mode {custom_mode}"


def _datagrams(packets: list[bytes]) -> list[bytes]:
    """Join packets into datagrams of at most MAX_DATAGRAM_BYTES (never splitting one)."""
    out: list[bytes] = []
    current = bytearray()
    for packet in packets:
        if current and len(current) + len(packet) > MAX_DATAGRAM_BYTES:
            out.append(bytes(current))
            current = bytearray()
        current += packet
    if current:
        out.append(bytes(current))
    return out


_AUTOPILOT_HANDLERS: dict[type, Handler] = {
    m.Heartbeat: Companion._on_heartbeat,
    m.GlobalPositionInt: Companion._on_gpi,
    m.LocalPositionNed: Companion._on_lpn,
    m.HomePosition: Companion._on_home,
    m.SystemTime: Companion._on_system_time,
    m.CommandAck: Companion._on_ack,
    m.StatusText: Companion._on_status_text,
}

_SETPOINT_ACTIONS: dict[Phase, Callable[[Companion, float], None]] = {
    Phase.CRUISE: Companion._plan,
    Phase.DESCEND: Companion._plan,
    Phase.HOVER: Companion._hold_goal,
}
