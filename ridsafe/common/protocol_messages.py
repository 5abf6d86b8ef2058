"""Domain messages of the ground-station protocols: parameters, missions, commands in
COMMAND_INT form, and the extra telemetry ground stations expect (common.xml).

Same rules as :mod:`ridsafe.common.messages` (which re-exports these and includes them in
its ``Message`` union): frozen dataclasses, units in the names, no MAVLink scales. Positions
in COMMAND_INT and MISSION_ITEM_INT ride in ``params[4:7]`` as in COMMAND_LONG: latitude and
longitude in degrees for global frames, x and y in metres for local ones, then z in metres.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import TypeAlias

from ridsafe.common.frozen import quick_init

Params7: TypeAlias = tuple[float, float, float, float, float, float, float]


class MissionType(enum.IntEnum):
    MISSION = 0
    FENCE = 1
    RALLY = 2
    ALL = 255


class MissionResult(enum.IntEnum):
    """MAV_MISSION_RESULT."""

    ACCEPTED = 0
    ERROR = 1
    UNSUPPORTED_FRAME = 2
    UNSUPPORTED = 3
    NO_SPACE = 4
    INVALID = 5
    INVALID_SEQUENCE = 13
    DENIED = 14
    OPERATION_CANCELLED = 15


class ParamType(enum.IntEnum):
    """MAV_PARAM_TYPE the sim uses (ArduPilot sends every value as a float)."""

    INT8 = 2
    INT16 = 4
    INT32 = 6
    REAL32 = 9


class LandedState(enum.IntEnum):
    UNDEFINED = 0
    ON_GROUND = 1
    IN_AIR = 2
    TAKEOFF = 3
    LANDING = 4


@quick_init
@dataclass(frozen=True, slots=True)
class CommandInt:
    target_system: int
    target_component: int
    frame: int
    command: int
    current: int
    autocontinue: int
    params: Params7


@quick_init
@dataclass(frozen=True, slots=True)
class ParamRequestList:
    target_system: int
    target_component: int


@quick_init
@dataclass(frozen=True, slots=True)
class ParamRequestRead:
    """``param_index`` -1: look up by ``param_id``."""

    target_system: int
    target_component: int
    param_id: str
    param_index: int


@quick_init
@dataclass(frozen=True, slots=True)
class ParamSet:
    target_system: int
    target_component: int
    param_id: str
    value: float
    param_type: int


@quick_init
@dataclass(frozen=True, slots=True)
class ParamValue:
    param_id: str
    value: float
    param_type: int
    param_count: int
    param_index: int


@quick_init
@dataclass(frozen=True, slots=True)
class AutopilotVersion:
    capabilities: int
    flight_sw_version: int
    board_version: int
    vendor_id: int
    product_id: int
    uid: int


@quick_init
@dataclass(frozen=True, slots=True)
class ExtendedSysState:
    vtol_state: int
    landed_state: int


@quick_init
@dataclass(frozen=True, slots=True)
class GpsRawInt:
    time_boot_s: float
    fix_type: int
    lat_deg: float
    lon_deg: float
    alt_msl_m: float
    hdop: float
    vdop: float
    ground_speed_m_s: float
    course_deg: float
    satellites_visible: int


@quick_init
@dataclass(frozen=True, slots=True)
class VfrHud:
    airspeed_m_s: float
    groundspeed_m_s: float
    heading_deg: int
    throttle_pct: int
    alt_msl_m: float
    climb_m_s: float


@quick_init
@dataclass(frozen=True, slots=True)
class BatteryStatus:
    voltage_v: float
    current_a: float
    remaining_pct: int


@quick_init
@dataclass(frozen=True, slots=True)
class RcChannels:
    """``channels_us``: the 18 RC inputs (pulse widths, us); 0 for absent channels."""

    time_boot_s: float
    channel_count: int
    channels_us: tuple[int, ...]
    rssi: int


@quick_init
@dataclass(frozen=True, slots=True)
class Timesync:
    """``tc1_ns`` 0: a request; otherwise the answer's own clock."""

    tc1_ns: int
    ts1_ns: int


@quick_init
@dataclass(frozen=True, slots=True)
class RequestDataStream:
    target_system: int
    target_component: int
    stream_id: int
    rate_hz: int
    start: bool


@quick_init
@dataclass(frozen=True, slots=True)
class MissionRequestList:
    target_system: int
    target_component: int
    mission_type: int


@quick_init
@dataclass(frozen=True, slots=True)
class MissionCount:
    target_system: int
    target_component: int
    count: int
    mission_type: int


@quick_init
@dataclass(frozen=True, slots=True)
class MissionRequestInt:
    target_system: int
    target_component: int
    seq: int
    mission_type: int


@quick_init
@dataclass(frozen=True, slots=True)
class MissionRequest:
    """The deprecated float form; answered with MISSION_ITEM."""

    target_system: int
    target_component: int
    seq: int
    mission_type: int


@quick_init
@dataclass(frozen=True, slots=True)
class MissionItemInt:
    target_system: int
    target_component: int
    seq: int
    frame: int
    command: int
    current: int
    autocontinue: int
    params: Params7
    mission_type: int


@quick_init
@dataclass(frozen=True, slots=True)
class MissionItem:
    """The deprecated float form of MISSION_ITEM_INT (same fields)."""

    target_system: int
    target_component: int
    seq: int
    frame: int
    command: int
    current: int
    autocontinue: int
    params: Params7
    mission_type: int


@quick_init
@dataclass(frozen=True, slots=True)
class MissionAck:
    target_system: int
    target_component: int
    result: int
    mission_type: int


@quick_init
@dataclass(frozen=True, slots=True)
class MissionClearAll:
    target_system: int
    target_component: int
    mission_type: int


@quick_init
@dataclass(frozen=True, slots=True)
class MissionSetCurrent:
    target_system: int
    target_component: int
    seq: int


@quick_init
@dataclass(frozen=True, slots=True)
class MissionCurrent:
    seq: int
    total: int


@quick_init
@dataclass(frozen=True, slots=True)
class MissionItemReached:
    seq: int


@quick_init
@dataclass(frozen=True, slots=True)
class FileTransferProtocol:
    """MAVLink FTP: ``payload`` (<= 251 bytes) is the FTP packet (header + data)."""

    target_network: int
    target_system: int
    target_component: int
    payload: bytes


ProtocolMessage: TypeAlias = (
    CommandInt
    | ParamRequestList
    | ParamRequestRead
    | ParamSet
    | ParamValue
    | AutopilotVersion
    | ExtendedSysState
    | GpsRawInt
    | VfrHud
    | BatteryStatus
    | RcChannels
    | Timesync
    | RequestDataStream
    | MissionRequestList
    | MissionCount
    | MissionRequestInt
    | MissionRequest
    | MissionItemInt
    | MissionItem
    | MissionAck
    | MissionClearAll
    | MissionSetCurrent
    | MissionCurrent
    | MissionItemReached
    | FileTransferProtocol
)
