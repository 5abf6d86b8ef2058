"""The companion computer of one aircraft, sans I/O: ``handle(now_s, inbound) -> outbound``.

Endpoints (``common.shell``): ``"autopilot"`` (MAVLink to the flight controller and, on the
same link, the RID transponder, component 236; other systems and components are refused
there) and ``"gcs"`` (observations up, unsafe regions and alerts down; MAVLink 2 signing
when a key is configured). Identity: the vehicle's system id, component 191
(MAV_COMP_ID_ONBOARD_COMPUTER), HEARTBEAT type 18 at ``heartbeat_hz`` on both links. Only
common.xml messages go to the autopilot.

``Companion`` composes its parts and calls them in a fixed order each step:

1. the shell parses what came in: the autopilot's messages go to ``AutopilotWatch``
   (telemetry, heartbeat) and COMMAND_ACKs to ``MissionDriver``; the transponder's to the
   RID receiver (``receivers``); the GCS's regions and alerts to ``GcsWatch``;
2. the links are watched (autopilot heartbeat lost / back; GCS seen / lost; regions expire);
3. ``MissionDriver``: the mission's commands;
4. ``OwnRidBroadcaster`` (rid.py): own Remote ID to the transponder;
5. ``ObservationReporter``: heard frames -> neighbours and observations; a due batch goes
   to the GCS;
6. ``PlannerDriver``: in CRUISE / DESCEND every ``replan_period_s`` a planned setpoint, in
   HOVER the goal;
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

import math
from dataclasses import asdict, fields

from ridsafe.common import codec, topics
from ridsafe.common import messages as m
from ridsafe.common.errors import ClockError
from ridsafe.common.heard import RidFrameDecoder
from ridsafe.common.logsink import LogSink
from ridsafe.common.shell import AppShell, Datagrams, Endpoint, from_system
from ridsafe.companion.autopilot_link import AutopilotWatch
from ridsafe.companion.config import (
    AUTOPILOT_COMPONENT,
    COMPANION_COMPONENT,
    TRANSPONDER_COMPONENT,
    CompanionConfig,
    CompanionSpec,
)
from ridsafe.companion.events import CompanionLog
from ridsafe.companion.gcs_link import GcsWatch
from ridsafe.companion.mission import Phase
from ridsafe.companion.mission_driver import MissionDriver
from ridsafe.companion.neighbours import NeighbourTable
from ridsafe.companion.observations import ObservationReporter
from ridsafe.companion.planner_api import Planner, PlannerDecision
from ridsafe.companion.planner_driver import PlannerDriver
from ridsafe.companion.receivers import RidReceiver, TransponderReceiver
from ridsafe.companion.regions import RegionStore
from ridsafe.companion.rid import OwnRidBroadcaster, Periodic
from ridsafe.companion.telemetry import OwnTelemetry

__all__ = ["AUTOPILOT", "GCS", "Companion"]

AUTOPILOT = "autopilot"
GCS = "gcs"
# HEARTBEAT of an onboard computer (MAV_TYPE_ONBOARD_CONTROLLER, MAV_AUTOPILOT_INVALID)
_OWN_HEARTBEAT = m.Heartbeat(
    int(m.MavType.ONBOARD_CONTROLLER), int(m.MavAutopilot.INVALID), 0, 0, int(m.MavState.ACTIVE)
)


class Companion:
    """One aircraft's companion computer; see the module docstring.

    ``receiver``: where heard RID frames come from (default: the transponder on the
    autopilot link). ``frame_decoder``: reads them; companions in one process may share one,
    so that a broadcast heard by all of them is decoded once.
    """

    def __init__(
        self,
        spec: CompanionSpec,
        config: CompanionConfig,
        planner: Planner,
        sink: LogSink,
        signing: codec.SigningConfig | None = None,
        receiver: RidReceiver | None = None,
        frame_decoder: RidFrameDecoder | None = None,
        autopilot_signing: codec.SigningConfig | None = None,
    ) -> None:
        """``signing``: the GCS link's MAVLink 2 signing; ``autopilot_signing``: the
        autopilot link's (optional, as ArduPilot's; default unsigned)."""
        self.spec = spec
        self.config = config
        self.sink = sink
        sysid = spec.sysid
        codec.warm_up_batches()  # its batch of reports: the kernels loaded before the run
        self.shell = AppShell(f"companion/{sysid}")
        # columnar: the transponder's reports of a datagram come decoded together
        own_link = codec.MavlinkLink(sysid, COMPANION_COMPONENT, autopilot_signing, columnar=True)
        accept = from_system(sysid, (AUTOPILOT_COMPONENT, TRANSPONDER_COMPONENT))
        self.shell.add(Endpoint(AUTOPILOT, own_link, accept=accept))
        self.shell.add(Endpoint(GCS, codec.MavlinkLink(sysid, COMPANION_COMPONENT, signing)))
        self.own = OwnTelemetry()
        self.log = CompanionLog(sysid, sink, self.own)
        self.autopilot = AutopilotWatch(config, self.own, self.log)
        self.gcs = GcsWatch(config, self.own, self.log)
        self.mission = MissionDriver(spec, config, self.own, self.autopilot, self.log)
        self.rid = OwnRidBroadcaster(spec.serial, spec.operator_id, config)
        self.receiver: RidReceiver = receiver if receiver is not None else TransponderReceiver()
        self.neighbours = NeighbourTable(spec.serial, config.neighbour_max_age_s)
        self.observations = ObservationReporter(
            sysid,
            config.observation_batch_s,
            config.max_extrapolation_s,
            self.neighbours,
            frame_decoder,
        )
        self.pilot = PlannerDriver(spec, config, planner, self.own, self.log)
        self.transponder_arm_status: m.OdidArmStatus | None = None
        self.t_s = -math.inf
        self._heartbeat = Periodic(1.0 / config.heartbeat_hz)
        self._counters = Periodic(config.counters_period_s, config.counters_period_s)

    # -- the sans-I/O step ------------------------------------------------------------------

    def handle(self, now_s: float, inbound: Datagrams) -> Datagrams:
        """Consume inbound datagrams, act for ``now_s``, return outbound datagrams."""
        if not math.isfinite(now_s) or now_s < self.t_s:
            raise ClockError(f"companion time must not go backwards: {self.t_s} -> {now_s}")
        self.t_s = now_s
        self.shell.advance_signing_clocks(now_s)
        self.shell.dispatch(inbound, lambda ep, received: self._dispatch(now_s, ep.name, received))
        self.autopilot.watch(now_s)
        self.gcs.watch(now_s)
        for command in self.mission.step(now_s):
            self.shell.send(AUTOPILOT, command)
        rid_due = self.rid.broadcast(
            now_s, self.own, self.mission.emergency(), self.config.max_extrapolation_s
        )
        for message in rid_due:
            self.shell.send(AUTOPILOT, message)
        self.observations.hear(self.receiver.poll(now_s))
        self.observations.report(now_s, self.own, self.gcs_seen, self._reports_to_gcs, self.sink)
        self.pilot.step(now_s, self.mission, self.neighbours, self.regions, self._to_autopilot)
        self._periodic(now_s)
        return self.shell.flush()

    def finish(self, now_s: float) -> Datagrams:
        """At the end of a run: send what is still batched and log the counters."""
        self.observations.finish(now_s, self.own, self.gcs_seen, self._reports_to_gcs, self.sink)
        self._log_counters(now_s)
        return self.shell.flush()

    # -- queries ----------------------------------------------------------------------------

    @property
    def phase(self) -> Phase:
        return self.mission.phase

    @property
    def regions(self) -> RegionStore:
        return self.gcs.regions

    @property
    def gcs_seen(self) -> bool:
        return self.gcs.seen_s is not None

    @property
    def last_decision(self) -> PlannerDecision | None:
        return self.pilot.last_decision

    @property
    def planner(self) -> Planner:
        return self.pilot.planner

    def sim_time(self, now_s: float) -> float:
        return self.own.sim_time(now_s)

    def emergency(self) -> bool:
        return self.mission.emergency()

    def counters_snapshot(self) -> dict[str, int]:
        """Every counter of this companion, flat: ``"autopilot.bad_data"``, ``"regions.live"``."""
        out: dict[str, int] = {}
        for name, counters in self.shell.link_counters().items():
            for f in fields(counters):
                value = getattr(counters, f.name)
                if isinstance(value, int):
                    out[f"{name}.{f.name}"] = value
        core = self.shell.counters.as_dict()
        core.update(self.shell.edge_counters())
        for part in (self.autopilot, self.gcs, self.mission, self.pilot):
            core.update(asdict(part.counters))
        groups: dict[str, dict[str, int]] = {
            "companion": core,
            "receiver": self.receiver.counters(),
            "observations": asdict(self.observations.counters),
            "rid": asdict(self.rid.counters),
            "regions": self.regions.counters_dict(),
            "neighbours": {"unusable": self.neighbours.unusable, "live": len(self.neighbours)},
        }
        for group, values in groups.items():
            out.update({f"{group}.{k}": int(v) for k, v in values.items()})
        return out

    # -- inside the step --------------------------------------------------------------------

    def _dispatch(self, now_s: float, endpoint: str, received: codec.Received) -> None:
        msg = received.message
        if endpoint == GCS:
            self.gcs.on_message(now_s, received)
        elif received.src_component == TRANSPONDER_COMPONENT:
            self._from_transponder(now_s, msg)
        elif isinstance(msg, m.CommandAck):
            self.mission.on_ack(now_s, msg)
        else:
            self.autopilot.on_message(now_s, msg)

    def _from_transponder(self, now_s: float, msg: m.Message) -> None:
        if isinstance(msg, m.OdidArmStatus):
            previous = self.transponder_arm_status
            if previous is None or previous.status != msg.status:
                detail = "ready" if msg.status == 0 else f"not ready: {msg.error}"
                self.log.event(now_s, "rid_arm_status", detail, status=msg.status)
            self.transponder_arm_status = msg
        elif not isinstance(msg, m.Heartbeat | m.CommandAck):
            self.receiver.on_transponder(now_s, msg)

    def _reports_to_gcs(self, messages: list[m.Message]) -> None:
        self.shell.send_all(GCS, messages)

    def _to_autopilot(self, message: m.Message) -> None:
        self.shell.send(AUTOPILOT, message)

    def _periodic(self, now_s: float) -> None:
        if self._heartbeat.due(now_s):
            self.shell.send(AUTOPILOT, _OWN_HEARTBEAT)
            self.shell.send(GCS, _OWN_HEARTBEAT)
        if self._counters.due(now_s):
            self._log_counters(now_s)

    def _log_counters(self, now_s: float) -> None:
        record: dict[str, object] = {
            "app": f"companion/{self.spec.sysid}",
            "counters": self.counters_snapshot(),
        }
        self.log.record(topics.APP_COUNTERS, now_s, record)
