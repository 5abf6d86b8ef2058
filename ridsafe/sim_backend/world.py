"""The sim backend core, sans I/O: ``handle(now_s, inbound) -> outbound``.

One ``SimBackend`` holds every vehicle of a scenario (benign aircraft 1..N, the spoofers
N + 1.., then the ghosts' transmitters: ``ridsafe.sim_backend.adversaries``), each with
an ArduCopter-like autopilot and a Remote ID transponder, and the radio channel between
the transponders. It speaks MAVLink bytes on named endpoints:

- ``v{i}/companion``: vehicle i's companion-computer link (autopilot compid 1 and
  transponder compid 236 share it);
- ``v{i}/gcs``: vehicle i's ground-station stream (autopilot only), SITL's ``--out``.

A runner (UDP, lockstep) maps endpoint names to sockets or to in-memory peers. Each call:

1. parse inbound bytes per endpoint; route commands (COMMAND_LONG / COMMAND_INT), setpoints,
   RID messages, and the ground-station protocols (parameters, missions, data streams,
   TIMESYNC: :mod:`.link_protocols`, one ``LinkResponder`` per endpoint);
2. advance physics and controllers of all vehicles to ``now_s`` (one compiled call);
3. run every autopilot's mode logic; let the spoofers and ghosts broadcast;
4. carry this tick's RID frames over the radio to the other transponders;
5. emit due telemetry, heartbeats, STATUSTEXTs; return bytes per endpoint.
"""

from __future__ import annotations

import dataclasses
import enum
import logging
import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ridsafe.common import codec, rng, topics
from ridsafe.common import messages as m
from ridsafe.common import protocol_messages as pm
from ridsafe.common.adversary import AdversaryRole
from ridsafe.common.errors import ClockError
from ridsafe.common.logsink import ItemRows, LogSink, NullSink
from ridsafe.common.scenario import Scenario
from ridsafe.common.shell import (
    AppShell,
    Datagrams,
    Endpoint,
    from_system,
    link_counter_values,
)
from ridsafe.sim_backend import telemetry
from ridsafe.sim_backend.adversaries import Adversaries
from ridsafe.sim_backend.autopilot import (
    Autopilot,
    CommandContext,
    HomeFrame,
    VehicleSample,
)
from ridsafe.sim_backend.config import SimConfig
from ridsafe.sim_backend.dynamics import EULER, IDX_PSI, POS_ENU, STATE_SIZE, VEL_ENU
from ridsafe.sim_backend.link_protocols import LINK_MESSAGES, LinkResponder, timesync_answer
from ridsafe.sim_backend.radio import RadioChannel, Reception, Receptions, Transmission
from ridsafe.sim_backend.telemetry import FleetSnapshot, TelemetrySchedule
from ridsafe.sim_backend.transponder import (
    STATIC_PERIOD_S,
    TRANSPONDER_COMPONENT,
    Transponder,
    frame_heard_together,
)
from ridsafe.sim_backend.vehicles import OctorotorFleet

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
#: The receptions of a tick with nothing on the air.
NOTHING_HEARD = Receptions.join([], [])
#: Receptions a tick must hold for the sim to frame its transponders' reports together
#: (``codec.frame_rid_reports``: about 60 us a tick, then 0.5 us a report, against 3 us a
#: report one message at a time; the bytes are the same either way).
_FRAMED_TOGETHER_FROM = 32
AUTOPILOT_COMPONENT = 1
_ODID_INBOUND = (
    m.OdidBasicId,
    m.OdidLocation,
    m.OdidSystem,
    m.OdidSystemUpdate,
    m.OdidOperatorId,
    m.OdidSelfId,
    m.OdidRaw,
)


class EndpointKind(enum.Enum):
    COMPANION = "companion"
    GCS = "gcs"


def endpoint_name(sysid: int, kind: EndpointKind) -> str:
    return f"v{sysid}/{kind.value}"


@dataclass
class _Port:
    """One vehicle endpoint: the shell's endpoint and what the vehicle keeps for it."""

    endpoint: Endpoint
    sysid: int
    kind: EndpointKind
    schedule: TelemetrySchedule
    responder: LinkResponder

    @property
    def name(self) -> str:
        return self.endpoint.name


@dataclass
class BackendCounters:
    """Inbound traffic the backend refused, by reason (the shell counts unknown endpoints,
    the links malformed bytes)."""

    wrong_vehicle: int = 0
    transponder_commands: int = 0


@dataclass(frozen=True)
class Truth:
    """The state of every vehicle (scenario ENU) at one tick, for logs and metrics."""

    t_s: float
    p_enu_m: FloatArray  # (N, 3)
    v_enu_m_s: FloatArray  # (N, 3)
    euler_rad: FloatArray  # (N, 3) phi, theta, psi
    armed: NDArray[np.bool_]  # (N,)
    modes: tuple[int, ...]
    spoofer_claimed_p_enu_m: FloatArray | None  # (3,) the first spoofer's


class SimBackend:
    """Every vehicle of one scenario behind MAVLink endpoints; see the module docstring."""

    def __init__(
        self,
        scenario: Scenario,
        config: SimConfig | None = None,
        kinds: Iterable[EndpointKind] = (EndpointKind.COMPANION, EndpointKind.GCS),
        sink: LogSink | None = None,
        companion_signing: codec.SigningConfig | None = None,
    ) -> None:
        """``companion_signing``: MAVLink 2 signing on the companion ports, as ArduPilot
        does with a key set (``SETUP_SIGNING``): what the autopilot and its transponder send
        there is signed, and only frames with a valid signature are taken (so only they
        can earn the port's peer lock). Default: unsigned."""
        self.scenario = scenario
        self.companion_signing = companion_signing
        self.config = config if config is not None else SimConfig()
        self.sink: LogSink = sink if sink is not None else NullSink()
        self._next_truth_log_s = 0.0
        self.counters = BackendCounters()
        self.n_vehicles = scenario.vehicle_count
        self.t_s = 0.0
        self.adversaries = Adversaries(scenario, lambda i: self.fleet.state_of(i)[POS_ENU])
        self.fleet = OctorotorFleet(
            self.n_vehicles, self.config.vehicle, self.config.controller, self._initial_state()
        )
        self._samples_kept: tuple[float, list[VehicleSample]] | None = None  # (fleet t_s, ...)
        self.homes = [HomeFrame(scenario.origin, s[POS_ENU]) for s in self._initial_state()]
        phases = rng.stream(scenario.seed, "sim/transponders").uniform(
            0.0, STATIC_PERIOD_S, self.n_vehicles
        )
        self.transponders = [
            Transponder(
                i + 1,
                scenario.serial_of(i + 1).encode("ascii"),
                float(phases[i]),
                self.config.rid_static_as_pack,
            )
            for i in range(self.n_vehicles)
        ]
        self.autopilots = [self._make_autopilot(i) for i in range(self.n_vehicles)]
        self.radio = RadioChannel(
            scenario.radio,
            [scenario.tx_power_dbm_of(i + 1) for i in range(self.n_vehicles)],
            rng.stream(scenario.seed, "sim/radio"),
        )
        spoofers = [a for a in self.adversaries.items if a.role is AdversaryRole.SPOOFER]
        self.spoofer_index = spoofers[0].index if spoofers else None  # the first spoofer
        codec.warm_up_batches()  # the RID frames it carries: the kernel loaded before the run
        self.shell = AppShell("sim")
        self.endpoints = {
            endpoint_name(i + 1, kind): self._make_port(i + 1, kind)
            for i in range(self.n_vehicles)
            for kind in kinds
        }
        #: Per vehicle index: its companion endpoint, where it has one (RID reports go there).
        self._companion_ports = [
            self.endpoints.get(endpoint_name(i + 1, EndpointKind.COMPANION))
            for i in range(self.n_vehicles)
        ]
        self.last_transmissions: list[Transmission] = []
        self.last_heard = NOTHING_HEARD  # the receptions of last_transmissions
        self._pending_air: list[Transmission] = []
        self._next_periodic_s = 0.0
        for adversary in self.adversaries.items:
            if adversary.airborne:
                self._launch_spoofer(adversary.index)

    # -- construction ---------------------------------------------------------------------

    def _initial_state(self) -> FloatArray:
        state = np.zeros((self.n_vehicles, STATE_SIZE))
        for i, aircraft in enumerate(self.scenario.aircraft):
            state[i, POS_ENU] = (aircraft.start_enu_m[0], aircraft.start_enu_m[1], 0.0)
            state[i, IDX_PSI] = math.pi / 2  # facing north
        for adversary in self.adversaries.items:
            i = adversary.index
            state[i, POS_ENU], state[i, VEL_ENU], state[i, IDX_PSI] = (
                self.adversaries.initial_state(i)
            )
        return state

    def _make_autopilot(self, i: int) -> Autopilot:
        mission = None
        adversary = self.adversaries.by_index.get(i)
        if adversary is not None and adversary.airborne:
            mission = self.adversaries.mission(i)
        return Autopilot(
            sysid=i + 1,
            vehicle=i,
            home=self.homes[i],
            actuators=self.fleet,
            config=self.config.autopilot,
            mission=mission,
            remote_id_error=self.transponders[i].ready_error,
            controller=self.config.controller,
        )

    def _make_port(self, sysid: int, kind: EndpointKind) -> _Port:
        """Vehicle ``sysid``'s endpoint of ``kind``: the autopilot (component 1) parses and
        sends; on the companion link its RID transponder (236) sends too."""
        senders = {}
        accept = None
        signing = None
        if kind is EndpointKind.COMPANION:  # only the vehicle's own companion (its system id)
            signing = self.companion_signing
            senders[TRANSPONDER_COMPONENT] = codec.MavlinkLink(
                sysid, TRANSPONDER_COMPONENT, signing
            )
            accept = from_system(sysid)
        link = codec.MavlinkLink(sysid, AUTOPILOT_COMPONENT, signing)
        name = endpoint_name(sysid, kind)
        endpoint = self.shell.add(Endpoint(name, link, accept=accept, senders=senders))
        rates = self.config.telemetry_hz
        schedule = TelemetrySchedule(rates.by_id(), rates.initial_by_id())
        serial = 1 if kind is EndpointKind.COMPANION else 0  # SRx_ parameters of the link
        return _Port(endpoint, sysid, kind, schedule, LinkResponder(sysid, serial))

    def _launch_spoofer(self, i: int) -> None:
        """A spoofer (or a hovering ghost transmitter) starts airborne, armed, flying its
        mission in AUTO."""
        autopilot = self.autopilots[i]
        self.fleet.arm(i)
        autopilot.armed = True
        autopilot.mode = m.CopterMode.AUTO
        autopilot.takeoff_alt_enu_m = float(self.fleet.state_of(i)[2])
        autopilot.update(0.0, self._samples()[i])

    # -- the sans-I/O step ----------------------------------------------------------------

    def handle(self, now_s: float, inbound: Iterable[tuple[str, bytes]]) -> Datagrams:
        """Consume inbound datagrams, advance to ``now_s``, return outbound datagrams."""
        if not math.isfinite(now_s) or now_s < self.t_s - 1e-9:
            raise ClockError(f"sim time must not go backwards: now {self.t_s} s, asked {now_s} s")
        if self.companion_signing is not None:
            self.shell.advance_signing_clocks(now_s)
        samples = self._samples()
        self.shell.dispatch(
            inbound,
            lambda endpoint, received: self._route(
                self.endpoints[endpoint.name],
                received,
                samples[self.endpoints[endpoint.name].sysid - 1],
            ),
        )
        self.fleet.advance_to(now_s)
        self.t_s = now_s
        samples = self._samples()
        for autopilot, sample in zip(self.autopilots, samples, strict=True):
            autopilot.update(now_s, sample)
            for event in autopilot.take_events():
                self.sink.log(topics.SIM_EVENTS, now_s, event)
        if self.adversaries.histories:
            state = self.fleet.state
            self.adversaries.record(now_s, state[:, POS_ENU], state[:, VEL_ENU])
        self._spoofer_broadcast(now_s)
        self._carry_air(now_s)
        self._periodic(now_s)
        self._log(now_s)
        return self.shell.flush()

    def _log(self, now_s: float) -> None:
        """Truth at ``truth_log_hz`` and every RID frame sent and received (topics.py)."""
        if self.last_transmissions:
            items = [
                {"sender": tx.sender + 1, "msg_type": tx.payload[0] >> 4}
                for tx in self.last_transmissions
            ]
            self.sink.log(topics.RADIO_TX, now_s, {"items": items})
        if len(self.last_heard):
            heard, sent = self.last_heard, self.last_transmissions
            senders = np.array([tx.sender + 1 for tx in sent])[heard.transmission]
            msg_types = np.array([tx.payload[0] >> 4 for tx in sent])[heard.transmission]
            received = ItemRows(
                ("sender", "receiver", "msg_type", "rssi_dbm"),
                (senders.tolist(), (heard.receiver + 1).tolist(), msg_types.tolist(),
                 heard.rssi_dbm.tolist()),
            )  # fmt: skip
            self.sink.log(topics.RADIO_RX, now_s, {"items": received})
        if now_s >= self._next_truth_log_s - 1e-9:
            period = 1.0 / self.config.truth_log_hz
            self._next_truth_log_s = (math.floor(now_s / period + 1e-9) + 1) * period
            self.sink.log(topics.TRUTH, now_s, self.truth_record())

    def truth_record(self) -> dict[str, object]:
        truth = self.truth()
        spoofer = None if self.spoofer_index is None else self.spoofer_index + 1
        claimed = truth.spoofer_claimed_p_enu_m
        return {
            "sysid": list(range(1, self.n_vehicles + 1)),
            "p_enu_m": truth.p_enu_m.round(4).tolist(),
            "v_enu_m_s": truth.v_enu_m_s.round(4).tolist(),
            "armed": truth.armed.tolist(),
            "mode": list(truth.modes),
            "spoofer_sysid": spoofer,
            "spoofer_claimed_p_enu_m": None if claimed is None else claimed.round(4).tolist(),
            "adversaries": self.adversaries.truth_record(truth.t_s, truth.p_enu_m, truth.v_enu_m_s),
        }

    def _samples(self) -> list[VehicleSample]:
        """Every vehicle's truth now; the same list until the fleet advances (the sim moves
        its vehicles only by advancing them: a tick's first call gets the last tick's)."""
        fleet_t_s = self.fleet.t_s
        if self._samples_kept is not None and self._samples_kept[0] == fleet_t_s:
            return self._samples_kept[1]
        state = self.fleet.state
        positions, velocities = state[:, POS_ENU], state[:, VEL_ENU]
        samples = [
            VehicleSample(positions[i], velocities[i], psi, on_ground)
            for i, (psi, on_ground) in enumerate(
                zip(state[:, IDX_PSI].tolist(), self.fleet.on_ground.tolist(), strict=True)
            )
        ]
        self._samples_kept = (fleet_t_s, samples)
        return samples

    def _route(self, endpoint: _Port, received: codec.Received, sample: VehicleSample) -> None:
        msg = received.message
        i = endpoint.sysid - 1
        ctx = CommandContext(self.t_s, sample, endpoint.schedule)
        if isinstance(msg, _ODID_INBOUND):
            frame = self.transponders[i].on_message(self.t_s, msg)
            if frame is not None:
                self._pending_air.append(Transmission(self.t_s, i, frame))
            return
        if isinstance(msg, pm.Timesync):
            answer = timesync_answer(msg, self.t_s)
            if answer is not None:
                self._send(endpoint, answer)
            return
        target = getattr(msg, "target_system", None)
        if target is None:
            return  # heartbeats and other broadcasts from the peer: nothing to do
        if target not in (0, endpoint.sysid):
            self.counters.wrong_vehicle += 1
            logger.warning(
                "%s: %s for system %d dropped: this link is vehicle %d (have 1..%d)",
                endpoint.name,
                type(msg).__name__,
                target,
                endpoint.sysid,
                self.n_vehicles,
            )
            return
        autopilot = self.autopilots[i]
        if isinstance(msg, m.CommandLong | pm.CommandInt):
            self._command(endpoint, received, msg, ctx)
        elif isinstance(msg, m.SetMode):
            ack = autopilot.handle_set_mode(msg, ctx)
            self._send(endpoint, _addressed(ack, received))
        elif isinstance(msg, m.SetPositionTargetLocalNed):
            autopilot.handle_position_target(msg, ctx)
        elif isinstance(msg, LINK_MESSAGES):
            client = (received.src_system, received.src_component)
            for out in endpoint.responder.handle(msg, autopilot, endpoint.schedule, ctx, client):
                self._send(endpoint, out)

    def _command(
        self,
        endpoint: _Port,
        received: codec.Received,
        cmd: m.CommandLong | pm.CommandInt,
        ctx: CommandContext,
    ) -> None:
        if cmd.target_component == TRANSPONDER_COMPONENT:
            self.counters.transponder_commands += 1
            ack = m.CommandAck(cmd.command, int(m.MavResult.UNSUPPORTED), 0, 0)
            self._send(endpoint, _addressed(ack, received), transponder=True)
            return
        ack = self.autopilots[endpoint.sysid - 1].handle_command(cmd, ctx)
        self._send(endpoint, _addressed(ack, received))

    def _spoofer_broadcast(self, now_s: float) -> None:
        for adversary in self.adversaries.items:
            i = adversary.index
            state = self.fleet.state_of(i)
            for msg in adversary.broadcaster.due(now_s, state[POS_ENU], state[VEL_ENU]):
                frame = self.transponders[i].on_message(now_s, msg)
                if frame is not None:
                    self._pending_air.append(Transmission(now_s, i, frame))

    def _carry_air(self, now_s: float) -> None:
        for i, transponder in enumerate(self.transponders):
            self._pending_air.extend(
                Transmission(now_s, i, frame) for frame in transponder.due_static(now_s)
            )
        if self.adversaries.has_silences:  # nothing at all from a silent transmitter
            self._pending_air = [
                tx for tx in self._pending_air if not self.adversaries.silent(tx.sender, now_s)
            ]
        self.last_transmissions, self._pending_air = self._pending_air, []
        positions = self.fleet.state[:, POS_ENU]
        euler_rad = self.fleet.state[:, EULER]
        if not self.last_transmissions:
            self.last_heard = NOTHING_HEARD
        elif self.adversaries.has_random_power:
            self.last_heard = self._deliver_each(positions, euler_rad)
        else:
            self.last_heard = self.radio.deliver_columns(
                self.last_transmissions, positions, euler_rad
            )
        self._hand_over(self.last_transmissions, self.last_heard)

    def _hand_over(self, transmissions: list[Transmission], heard: Receptions) -> None:
        """Each receiver's transponder reports what it heard to its companion, frame by frame
        in the order heard: one RIDSAFE_RID_FRAME each (``Transponder.report``), framed
        together where a tick holds many (``frame_heard_together``: the same packets)."""
        transponders, companions = self.transponders, self._companion_ports
        if len(heard) >= _FRAMED_TOGETHER_FROM:
            links = [None if p is None else p.endpoint.senders.get(TRANSPONDER_COMPONENT)
                     for p in companions]  # fmt: skip
            framed = frame_heard_together(transponders, links, transmissions, heard)
            if framed is not None:
                for receiver, packets in framed:
                    port = companions[receiver]
                    assert port is not None
                    port.endpoint.outbox.extend(packets)
                return
        for t, receiver, rssi_dbm in zip(
            heard.transmission.tolist(),
            heard.receiver.tolist(),
            heard.rssi_dbm.tolist(),
            strict=True,
        ):
            tx = transmissions[t]
            report = transponders[receiver].report(
                tx.payload, transponders[tx.sender].radio_id, rssi_dbm
            )
            port = companions[receiver]
            if port is not None:
                self._send(port, report, transponder=True)

    def _deliver_each(self, positions: FloatArray, euler_rad: FloatArray) -> Receptions:
        """One transmission at a time, each random-power sender at a fresh power (the same
        draws of the channel, in the same order, as one ``deliver`` call)."""
        receivers_of, rssi_of = [], []
        for tx in self.last_transmissions:
            power_dbm = self.adversaries.power_dbm(tx.sender)
            if power_dbm is not None:
                self.radio.tx_power_dbm[tx.sender] = power_dbm
            heard = self.radio.deliver_columns([tx], positions, euler_rad)
            receivers_of.append(heard.receiver)
            rssi_of.append(heard.rssi_dbm)
        return Receptions.join(receivers_of, rssi_of)

    def _periodic(self, now_s: float) -> None:
        snapshot: FleetSnapshot | None = None
        for endpoint in self.endpoints.values():
            i = endpoint.sysid - 1
            for text in self.autopilots[i].take_status():
                for peer in self._endpoints_of(endpoint.sysid):
                    self._send(peer, text)
            due = endpoint.schedule.due(now_s)
            if not due:
                continue
            if snapshot is None:
                snapshot = FleetSnapshot(
                    now_s,
                    self.scenario.start_unix_s + now_s,
                    self.fleet.state,
                    self.homes,
                    self.scenario.origin,
                    self.fleet.on_ground,
                )
            for msg_id in due:
                self._send(endpoint, self._telemetry(msg_id, i, snapshot))
        if now_s >= self._next_periodic_s - 1e-9:
            self._next_periodic_s += 1.0 / max(self.config.transponder_heartbeat_hz, 1e-3)
            for endpoint in self.endpoints.values():
                if TRANSPONDER_COMPONENT in endpoint.endpoint.senders:
                    transponder = self.transponders[endpoint.sysid - 1]
                    self._send(endpoint, transponder.heartbeat(), transponder=True)
                    self._send(endpoint, transponder.arm_status(now_s), transponder=True)

    def _telemetry(self, msg_id: int, i: int, snapshot: FleetSnapshot) -> m.Message:
        return telemetry.BUILDERS[msg_id](snapshot, i, self.autopilots[i])

    def _endpoints_of(self, sysid: int) -> list[_Port]:
        return [e for e in self.endpoints.values() if e.sysid == sysid]

    def _send(self, port: _Port, msg: m.Message, transponder: bool = False) -> None:
        """Queue ``msg`` from the autopilot, or from the RID transponder (only the
        companion link has one; elsewhere the message is not sent)."""
        if not transponder:
            port.endpoint.send(msg)
        elif TRANSPONDER_COMPONENT in port.endpoint.senders:
            port.endpoint.send(msg, TRANSPONDER_COMPONENT)

    # -- for logs, metrics and tests ------------------------------------------------------

    @property
    def last_receptions(self) -> list[Reception]:
        """The receptions of ``last_transmissions``, one object each (``last_heard``)."""
        return self.last_heard.receptions(self.last_transmissions)

    def truth(self) -> Truth:
        state = self.fleet.state
        claimed = None
        if self.spoofer_index is not None:
            i = self.spoofer_index
            broadcaster = self.adversaries.by_index[i].broadcaster
            claimed, _ = broadcaster.claimed_state(self.t_s, state[i, POS_ENU], state[i, VEL_ENU])
        return Truth(
            self.t_s,
            state[:, POS_ENU],
            state[:, VEL_ENU],
            state[:, EULER],
            self.fleet.armed,
            tuple(int(a.mode) for a in self.autopilots),
            claimed,
        )

    def link_counters(self) -> dict[str, codec.LinkCounters]:
        return self.shell.link_counters()

    def valid_senders(self, name: str, data: bytes) -> set[tuple[int, int]]:
        """Who sent a genuine frame in ``data`` on ``name`` (``AppShell.valid_senders``)."""
        return self.shell.valid_senders(name, data)

    def counter_values(self) -> dict[str, int]:
        """Every counter of the backend, flat (the ``/app/counters`` record's)."""
        out = {f"link_{k}": v for k, v in link_counter_values(self.shell.link_totals()).items()}
        out.update(self.shell.counters.as_dict())
        out.update(self.shell.edge_counters())
        out.update(dataclasses.asdict(self.counters))
        return out

    def finish(self, now_s: float) -> None:
        """Log the final ``/app/counters`` (call once when the run ends)."""
        self.sink.log(topics.APP_COUNTERS, now_s, {"app": "sim", "counters": self.counter_values()})


def _addressed(ack: m.CommandAck, received: codec.Received) -> m.CommandAck:
    return m.CommandAck(
        ack.command, ack.result, received.src_system, received.src_component, ack.progress
    )
