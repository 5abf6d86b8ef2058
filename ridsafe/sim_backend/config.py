"""The sim backend's own configuration section (YAML ``sim:``).

Ports follow ArduPilot SITL's instance convention: vehicle i (1-based) is instance i - 1 and
uses base + 10 (i - 1):

- ``gcs_out_base`` (14550): vehicle i streams its autopilot's MAVLink to
  127.0.0.1:(14550 + 10 (i - 1)), like SITL's ``--out``, and takes commands from whoever
  answers on that stream (QGroundControl, MAVProxy ``udpin:127.0.0.1:14550``, pymavlink).
- ``companion_base`` (5760): the sim listens on 127.0.0.1:(5760 + 10 (i - 1)) for vehicle
  i's companion computer (``udpout:127.0.0.1:5760``); that link carries the autopilot
  (component 1) and the Remote ID transponder (component 236).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ridsafe.common.errors import FieldValueError
from ridsafe.sim_backend.autopilot import AutopilotConfig
from ridsafe.sim_backend.params import ControllerParams, OctorotorParams
from ridsafe.sim_backend.telemetry import TelemetryRatesHz

_MAX_VEHICLES = 256


@dataclass(frozen=True)
class SimPorts:
    host: str = "127.0.0.1"
    gcs_out_base: int = 14550
    companion_base: int = 5760
    instance_step: int = 10
    gcs_out_enabled: bool = True

    def __post_init__(self) -> None:
        for name in ("gcs_out_base", "companion_base"):
            port = getattr(self, name)
            if not 1024 <= port <= 65535 - self.instance_step * _MAX_VEHICLES:
                raise FieldValueError(name, f"expected a port in 1024..{65535 - 2560}, got {port}")
        if self.instance_step < 1:
            raise FieldValueError("instance_step", f"expected >= 1, got {self.instance_step}")

    def gcs_out_port(self, sysid: int) -> int:
        return self.gcs_out_base + self.instance_step * (sysid - 1)

    def companion_port(self, sysid: int) -> int:
        return self.companion_base + self.instance_step * (sysid - 1)


@dataclass(frozen=True)
class SimConfig:
    vehicle: OctorotorParams = field(default_factory=OctorotorParams)
    controller: ControllerParams = field(default_factory=ControllerParams)
    autopilot: AutopilotConfig = field(default_factory=AutopilotConfig)
    telemetry_hz: TelemetryRatesHz = field(default_factory=TelemetryRatesHz)
    ports: SimPorts = field(default_factory=SimPorts)
    transponder_heartbeat_hz: float = 1.0
    # Transponders broadcast the static RID messages as one message pack (Bluetooth 5 long
    # range, Wi-Fi) rather than a frame each (Bluetooth 4 legacy advertising).
    rid_static_as_pack: bool = True
    truth_log_hz: float = 10.0

    def __post_init__(self) -> None:
        for name in ("transponder_heartbeat_hz", "truth_log_hz"):
            value = getattr(self, name)
            if not 0.01 <= value <= 400.0:
                raise FieldValueError(name, f"expected 0.01..400 Hz, got {value}")
