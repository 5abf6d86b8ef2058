"""A sim backend and a ground station wired through memory with real MAVLink bytes."""

from __future__ import annotations

from collections.abc import Sequence

from ridsafe.common import codec
from ridsafe.common import messages as m
from ridsafe.common.frames import GeodeticOrigin
from ridsafe.common.scenario import AircraftConfig, RadioConfig, Scenario, SpooferConfig
from ridsafe.sim_backend.config import SimConfig
from ridsafe.sim_backend.world import EndpointKind, SimBackend

ORIGIN = GeodeticOrigin(36.1447, -86.8027, 180.0)


def scenario(n_aircraft: int = 2, spoofer: bool = False) -> Scenario:
    aircraft = tuple(
        AircraftConfig(f"RSAF8{k + 1:08d}", (30.0 * k, 0.0, 0.0), (300.0, 300.0, 0.0))
        for k in range(n_aircraft)
    )
    liar = (
        SpooferConfig("RSAF800000666", (-300.0, 0.0, 60.0), (300.0, 0.0, 60.0)) if spoofer else None
    )
    return Scenario(ORIGIN, aircraft, liar, RadioConfig(shadowing_sigma_db=0.0))


class SimPair:
    """``SimBackend`` + a ground station (sysid 255, compid 190) on one vehicle's endpoint."""

    def __init__(
        self,
        backend: SimBackend | None = None,
        sysid: int = 1,
        kind: EndpointKind = EndpointKind.GCS,
        dt_s: float = 0.02,
    ) -> None:
        self.backend = backend if backend is not None else SimBackend(scenario(), SimConfig())
        self.sysid = sysid
        self.endpoint = f"v{sysid}/{kind.value}"
        self.station = codec.MavlinkLink(255, 190)
        self.dt_s = dt_s
        self.t_s = 0.0
        self.received: list[codec.Received] = []

    def step(self, messages: Sequence[m.Message] = (), raw: bytes = b"") -> list[codec.Received]:
        data = self.station.pack_all(list(messages)) + raw
        inbound = [(self.endpoint, data)] if data else []
        self.t_s = round(self.t_s + self.dt_s, 9)
        got: list[codec.Received] = []
        for name, datagram in self.backend.handle(self.t_s, inbound):
            if name == self.endpoint:
                got.extend(self.station.feed(datagram))
        self.received.extend(got)
        return got

    def run(self, seconds: float) -> list[codec.Received]:
        got: list[codec.Received] = []
        for _ in range(round(seconds / self.dt_s)):
            got.extend(self.step())
        return got

    def command(self, command: int, *params: float, target_component: int = 1) -> m.CommandAck:
        padded = (tuple(params) + (0.0,) * 7)[:7]
        cmd = m.CommandLong(self.sysid, target_component, command, 0, padded)  # type: ignore[arg-type]
        acks = [r.message for r in self.step([cmd]) if isinstance(r.message, m.CommandAck)]
        assert len(acks) == 1, f"expected exactly one COMMAND_ACK, got {acks}"
        return acks[0]

    def latest(self, kind: type) -> m.Message:
        for received in reversed(self.received):
            if isinstance(received.message, kind):
                return received.message
        raise AssertionError(f"no {kind.__name__} received")

    def texts(self) -> list[str]:
        return [r.message.text for r in self.received if isinstance(r.message, m.StatusText)]

    def altitude_m(self) -> float:
        return -float(self.backend.homes[self.sysid - 1].enu_to_local_ned(self.position_enu())[2])

    def position_enu(self) -> tuple[float, float, float]:
        p = self.backend.truth().p_enu_m[self.sysid - 1]
        return (float(p[0]), float(p[1]), float(p[2]))

    def take_off(self, alt_m: float = 20.0) -> None:
        assert self.command(m.MavCmd.DO_SET_MODE, 1, m.CopterMode.GUIDED).result == 0
        assert self.command(m.MavCmd.COMPONENT_ARM_DISARM, 1).result == 0
        assert self.command(m.MavCmd.NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, alt_m).result == 0
        self.run(alt_m / 2.5 + 6.0)
