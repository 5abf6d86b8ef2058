"""Domain messages: one frozen dataclass per MAVLink message the apps exchange.

Units and frames are in the field names (``p_ned_m``, ``v_ned_m_s``, ``lat_deg``). Only
``ridsafe.common.codec`` knows MAVLink's scales (degE7, cm/s, mm, cdeg); everything else in
the project speaks these classes. Vectors are tuples, so instances are hashable and compare
by value. ``None`` stands for MAVLink's "unknown" sentinel values (e.g. an Open Drone ID
speed of 25500 cm/s).

Frames: ``ned`` is local North-East-Down about the vehicle's home / the scenario origin,
``frd`` the body frame Forward-Right-Down, ``geodetic`` WGS-84 latitude, longitude and
ellipsoidal altitude.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TypeAlias

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.frozen import quick_init
from ridsafe.common.mav_enums import (
    AlertState,
    CopterMode,
    MavAutopilot,
    MavCmd,
    MavFrame,
    MavModeFlag,
    MavResult,
    MavSeverity,
    MavState,
    MavType,
    OdidIdType,
    OdidMessageType,
    OdidStatus,
    OdidUaType,
    PositionTargetMask,
    RegionFlags,
    RidsafeDetector,
    RidTransport,
)
from ridsafe.common.protocol_messages import ProtocolMessage

#: Every message and, re-exported from ``mav_enums``, the enums their fields hold (``m.MavType``).
__all__ = [
    "FIRST_OPTIONAL_COLUMN",
    "OBSERVATION_COLUMNS",
    "AlertState",
    "Attitude",
    "CommandAck",
    "CommandLong",
    "CopterMode",
    "GlobalPositionInt",
    "Heartbeat",
    "HomePosition",
    "LocalPositionNed",
    "LockstepDone",
    "LockstepTick",
    "MavAutopilot",
    "MavCmd",
    "MavFrame",
    "MavModeFlag",
    "MavResult",
    "MavSeverity",
    "MavState",
    "MavType",
    "Message",
    "Observation",
    "ObservationPack",
    "ObservationRows",
    "OdidArmStatus",
    "OdidBasicId",
    "OdidIdType",
    "OdidLocation",
    "OdidMessageType",
    "OdidOperatorId",
    "OdidRaw",
    "OdidSelfId",
    "OdidStatus",
    "OdidSystem",
    "OdidSystemUpdate",
    "OdidUaType",
    "PositionTargetMask",
    "RegionFlags",
    "RidFrameReport",
    "RidFrameReports",
    "RidTransport",
    "RidsafeDetector",
    "SetMode",
    "SetPositionTargetLocalNed",
    "SpoofAlert",
    "StatusText",
    "SysStatus",
    "SystemTime",
    "UnsafeRegionMsg",
    "Vec3",
    "messages_in",
]

_SAFETY_ARMED = int(MavModeFlag.SAFETY_ARMED)

Vec3: TypeAlias = tuple[float, float, float]


# --- Autopilot link (standard common.xml messages) ------------------------------------------


@quick_init
@dataclass(frozen=True, slots=True)
class Heartbeat:
    mav_type: int
    autopilot: int
    base_mode: int
    custom_mode: int
    system_status: int

    @property
    def armed(self) -> bool:
        return bool(self.base_mode & _SAFETY_ARMED)  # an int: IntFlag's & is slow


@quick_init
@dataclass(frozen=True, slots=True)
class CommandLong:
    target_system: int
    target_component: int
    command: int
    confirmation: int
    params: tuple[float, float, float, float, float, float, float]


@quick_init
@dataclass(frozen=True, slots=True)
class CommandAck:
    command: int
    result: int
    target_system: int
    target_component: int
    progress: int = 0
    result_param2: int = 0


@quick_init
@dataclass(frozen=True, slots=True)
class SetMode:
    """Legacy SET_MODE message (pymavlink's ``set_mode`` still sends it)."""

    target_system: int
    base_mode: int
    custom_mode: int


@quick_init
@dataclass(frozen=True, slots=True)
class SetPositionTargetLocalNed:
    time_boot_s: float
    target_system: int
    target_component: int
    coordinate_frame: int
    type_mask: int
    p_ned_m: Vec3
    v_ned_m_s: Vec3
    a_ned_m_s2: Vec3
    yaw_rad: float
    yaw_rate_rad_s: float


@quick_init
@dataclass(frozen=True, slots=True)
class GlobalPositionInt:
    time_boot_s: float
    lat_deg: float
    lon_deg: float
    alt_msl_m: float
    relative_alt_m: float
    v_ned_m_s: Vec3
    heading_deg: float | None


@quick_init
@dataclass(frozen=True, slots=True)
class LocalPositionNed:
    time_boot_s: float
    p_ned_m: Vec3
    v_ned_m_s: Vec3


@quick_init
@dataclass(frozen=True, slots=True)
class Attitude:
    time_boot_s: float
    roll_rad: float
    pitch_rad: float
    yaw_rad: float
    rates_frd_rad_s: Vec3


@quick_init
@dataclass(frozen=True, slots=True)
class SysStatus:
    sensors_present: int
    sensors_enabled: int
    sensors_health: int
    load_pct: float
    battery_voltage_v: float | None
    battery_remaining_pct: int | None


@quick_init
@dataclass(frozen=True, slots=True)
class HomePosition:
    lat_deg: float
    lon_deg: float
    alt_msl_m: float
    p_ned_m: Vec3


@quick_init
@dataclass(frozen=True, slots=True)
class SystemTime:
    time_unix_s: float
    time_boot_s: float


@quick_init
@dataclass(frozen=True, slots=True)
class StatusText:
    severity: int
    text: str


# --- Open Drone ID (common.xml OPEN_DRONE_ID_*) -------------------------------------------


@quick_init
@dataclass(frozen=True, slots=True)
class OdidBasicId:
    id_or_mac: bytes
    id_type: int
    ua_type: int
    uas_id: bytes

    @property
    def uas_id_str(self) -> str:
        return self.uas_id.rstrip(b"\x00").decode("ascii", errors="replace")


@quick_init
@dataclass(frozen=True, slots=True)
class OdidLocation:
    id_or_mac: bytes
    status: int
    course_deg: float | None
    speed_horizontal_m_s: float | None
    speed_vertical_m_s: float | None
    lat_deg: float | None
    lon_deg: float | None
    alt_baro_m: float | None
    alt_geodetic_m: float | None
    height_reference: int
    height_m: float | None
    horizontal_accuracy: int
    vertical_accuracy: int
    barometer_accuracy: int
    speed_accuracy: int
    timestamp_s: float | None
    timestamp_accuracy: int


@quick_init
@dataclass(frozen=True, slots=True)
class OdidSystem:
    id_or_mac: bytes
    operator_location_type: int
    classification_type: int
    operator_lat_deg: float | None
    operator_lon_deg: float | None
    area_count: int
    area_radius_m: int
    area_ceiling_m: float | None
    area_floor_m: float | None
    category_eu: int
    class_eu: int
    operator_alt_geo_m: float | None
    timestamp_s: int


@quick_init
@dataclass(frozen=True, slots=True)
class OdidSystemUpdate:
    operator_lat_deg: float | None
    operator_lon_deg: float | None
    operator_alt_geo_m: float | None
    timestamp_s: int


@quick_init
@dataclass(frozen=True, slots=True)
class OdidOperatorId:
    id_or_mac: bytes
    operator_id_type: int
    operator_id: str


@quick_init
@dataclass(frozen=True, slots=True)
class OdidSelfId:
    id_or_mac: bytes
    description_type: int
    description: str


@quick_init
@dataclass(frozen=True, slots=True)
class OdidArmStatus:
    status: int
    error: str


@quick_init
@dataclass(frozen=True, slots=True)
class OdidRaw:
    """An Open Drone ID message passed through as its MAVLink field values
    (AUTHENTICATION and MESSAGE_PACK: nothing in the apps reads inside them)."""

    name: str
    fields: tuple[tuple[str, object], ...]


# --- ridsafe dialect (ids 61000-61099) --------------------------------------------------


@quick_init
@dataclass(frozen=True, slots=True)
class RidFrameReport:
    """One Remote ID frame a receiver heard, as it reports it: the ASTM F3411 bytes (one
    25-byte message or a message pack) with their signal strength, the sender as the radio
    layer knows it (MAC or the sim's radio id; b"" unknown) and how it travelled
    (RIDSAFE_RID_FRAME). The receive time is the holder's: see ``common.heard``."""

    frame: bytes
    rssi_dbm: float
    sender_id: bytes
    transport: int
    channel: int = 0


@dataclass(frozen=True, slots=True)
class RidFrameReports:
    """Consecutive RIDSAFE_RID_FRAME messages of one sender, decoded together (by a link
    with columnar decoding, as a companion's autopilot link): each the ``RidFrameReport``
    it was sent as, in order. Received only, never sent."""

    reports: tuple[RidFrameReport, ...]

    def __len__(self) -> int:
        return len(self.reports)


@quick_init
@dataclass(frozen=True, slots=True)
class Observation:
    """One received RID location broadcast with its RSSI, as reported to the GCS."""

    t_s: float
    rx_lat_deg: float
    rx_lon_deg: float
    rx_alt_m: float
    claimed_lat_deg: float
    claimed_lon_deg: float
    claimed_alt_m: float
    rid_timestamp_s: float
    rssi_dbm: float
    claimed_course_deg: float | None
    claimed_speed_horizontal_m_s: float | None
    claimed_speed_vertical_m_s: float | None
    uas_id: str


#: ``Observation``'s float fields in order: the columns of ``ObservationRows.values``.
OBSERVATION_COLUMNS = (
    "t_s",
    "rx_lat_deg",
    "rx_lon_deg",
    "rx_alt_m",
    "claimed_lat_deg",
    "claimed_lon_deg",
    "claimed_alt_m",
    "rid_timestamp_s",
    "rssi_dbm",
    "claimed_course_deg",
    "claimed_speed_horizontal_m_s",
    "claimed_speed_vertical_m_s",
)
#: The first of ``OBSERVATION_COLUMNS`` that may be None (NaN in ``ObservationRows``): the
#: last three.
FIRST_OPTIONAL_COLUMN = 9


_OBSERVATION_FLOATS = operator.attrgetter(*OBSERVATION_COLUMNS)


@quick_init
@dataclass(frozen=True, slots=True)
class ObservationPack:
    """One to three ``Observation`` of one receiver in one message (RIDSAFE_OBSERVATION_PACK,
    a companion's batch three at a time); a link decodes it to ``ObservationRows``."""

    observations: tuple[Observation, ...]


@dataclass(frozen=True, eq=False)
class ObservationRows:
    """Reports of one receiver as columns: row i of ``values`` holds the i-th ``Observation``'s
    float fields in ``OBSERVATION_COLUMNS`` order, NaN where it has None, and ``uas_id[i]``
    its id. Received: consecutive RIDSAFE_OBSERVATION(_PACK) messages of one sender decoded
    together (by a link with columnar decoding, as the GCS's are). Sent: a companion's batch,
    which a link sends as RIDSAFE_OBSERVATION_PACKs, three reports to a pack
    (``wire.encode_payloads``); on the wire each row is one report."""

    values: NDArray[np.float64]  # (n, len(OBSERVATION_COLUMNS)), read-only
    uas_id: tuple[str, ...]

    @classmethod
    def of(cls, observations: Sequence[Observation]) -> ObservationRows:
        """The rows of ``observations``, in order."""
        return cls.of_rows([_OBSERVATION_FLOATS(o) for o in observations],
                           [o.uas_id for o in observations])  # fmt: skip

    @classmethod
    def of_rows(
        cls, rows: Sequence[Sequence[float | None]], uas_id: Sequence[str]
    ) -> ObservationRows:
        """Rows of ``OBSERVATION_COLUMNS`` values (None where unknown) with their ids."""
        if len(rows) != len(uas_id):
            raise ValueError(f"ObservationRows: {len(rows)} rows, {len(uas_id)} ids")
        values = np.array(rows, dtype=np.float64)  # numpy makes None NaN in a float array
        values = values.reshape(len(rows), len(OBSERVATION_COLUMNS))
        values.setflags(write=False)
        return cls(values, tuple(uas_id))

    def __len__(self) -> int:
        return len(self.uas_id)

    def observations(self) -> list[Observation]:
        """Every row as the ``Observation`` it was sent as, in order."""
        return [self.observation(i) for i in range(len(self))]

    def observation(self, i: int) -> Observation:
        """Row ``i`` as the ``Observation`` it was sent as."""
        row = self.values[i].tolist()
        t_s, rx_lat, rx_lon, rx_alt, c_lat, c_lon, c_alt, rid_t, rssi, *optional = row
        course, speed_h, speed_v = (None if math.isnan(v) else v for v in optional)
        return Observation(
            t_s, rx_lat, rx_lon, rx_alt, c_lat, c_lon, c_alt, rid_t, rssi,
            course, speed_h, speed_v, self.uas_id[i],
        )  # fmt: skip


@quick_init
@dataclass(frozen=True, slots=True)
class UnsafeRegionMsg:
    """Chance-constrained ellipsoid (x - c)^T P^-1 (x - c) <= chi2_threshold."""

    t_s: float
    valid_until_s: float
    center_lat_deg: float
    center_lon_deg: float
    center_alt_m: float
    cov_ned_m2: tuple[float, float, float, float, float, float]  # xx, xy, xz, yy, yz, zz
    v_ned_m_s: Vec3
    chi2_threshold: float
    alpha: float
    track_id: int
    flags: int
    uas_id: str


@quick_init
@dataclass(frozen=True, slots=True)
class SpoofAlert:
    t_s: float
    statistic: float
    threshold: float
    detector: int
    state: int
    uas_id: str


@quick_init
@dataclass(frozen=True, slots=True)
class LockstepTick:
    t_s: float
    tick: int


@quick_init
@dataclass(frozen=True, slots=True)
class LockstepDone:
    t_s: float
    tick: int


Message: TypeAlias = (
    Heartbeat
    | CommandLong
    | CommandAck
    | SetMode
    | SetPositionTargetLocalNed
    | GlobalPositionInt
    | LocalPositionNed
    | Attitude
    | SysStatus
    | HomePosition
    | SystemTime
    | StatusText
    | OdidBasicId
    | OdidLocation
    | OdidSystem
    | OdidSystemUpdate
    | OdidOperatorId
    | OdidSelfId
    | OdidArmStatus
    | OdidRaw
    | RidFrameReport
    | RidFrameReports
    | Observation
    | ObservationPack
    | ObservationRows
    | UnsafeRegionMsg
    | SpoofAlert
    | LockstepTick
    | LockstepDone
    | ProtocolMessage
)


def messages_in(message: Message) -> int:
    """How many MAVLink messages ``message`` stands for: a run decoded together
    (``ObservationRows``, ``RidFrameReports``) one per row, any other one."""
    return len(message) if isinstance(message, ObservationRows | RidFrameReports) else 1
