"""The MAVLink enums the apps use (values from common.xml, ArduPilot and the ridsafe dialect).

``messages`` re-exports every one (``m.MavType`` and so on): the domain messages' fields hold
their values.
"""

from __future__ import annotations

import enum

# --- MAVLink enums used by the apps (values from common.xml / ArduPilot) -------------------


class MavType(enum.IntEnum):
    GCS = 6
    OCTOROTOR = 14
    ONBOARD_CONTROLLER = 18
    ODID = 34


class MavAutopilot(enum.IntEnum):
    GENERIC = 0
    ARDUPILOTMEGA = 3
    INVALID = 8


class MavModeFlag(enum.IntFlag):
    CUSTOM_MODE_ENABLED = 1
    TEST_ENABLED = 2
    AUTO_ENABLED = 4
    GUIDED_ENABLED = 8
    STABILIZE_ENABLED = 16
    HIL_ENABLED = 32
    MANUAL_INPUT_ENABLED = 64
    SAFETY_ARMED = 128


class MavState(enum.IntEnum):
    UNINIT = 0
    BOOT = 1
    CALIBRATING = 2
    STANDBY = 3
    ACTIVE = 4
    CRITICAL = 5
    EMERGENCY = 6
    POWEROFF = 7


class CopterMode(enum.IntEnum):
    """ArduCopter flight modes (HEARTBEAT.custom_mode)."""

    STABILIZE = 0
    ACRO = 1
    ALT_HOLD = 2
    AUTO = 3
    GUIDED = 4
    LOITER = 5
    RTL = 6
    CIRCLE = 7
    LAND = 9
    BRAKE = 17


class MavCmd(enum.IntEnum):
    NAV_RETURN_TO_LAUNCH = 20
    NAV_LAND = 21
    NAV_TAKEOFF = 22
    DO_SET_MODE = 176
    COMPONENT_ARM_DISARM = 400
    SET_MESSAGE_INTERVAL = 511
    REQUEST_MESSAGE = 512


class MavResult(enum.IntEnum):
    ACCEPTED = 0
    TEMPORARILY_REJECTED = 1
    DENIED = 2
    UNSUPPORTED = 3
    FAILED = 4
    IN_PROGRESS = 5
    CANCELLED = 6


class MavFrame(enum.IntEnum):
    GLOBAL = 0
    LOCAL_NED = 1
    LOCAL_OFFSET_NED = 7
    BODY_NED = 8
    BODY_OFFSET_NED = 9
    BODY_FRD = 12


class MavSeverity(enum.IntEnum):
    EMERGENCY = 0
    ALERT = 1
    CRITICAL = 2
    ERROR = 3
    WARNING = 4
    NOTICE = 5
    INFO = 6
    DEBUG = 7


class PositionTargetMask(enum.IntFlag):
    """POSITION_TARGET_TYPEMASK: a set bit means "ignore this field"."""

    X_IGNORE = 1
    Y_IGNORE = 2
    Z_IGNORE = 4
    VX_IGNORE = 8
    VY_IGNORE = 16
    VZ_IGNORE = 32
    AX_IGNORE = 64
    AY_IGNORE = 128
    AZ_IGNORE = 256
    FORCE_SET = 512
    YAW_IGNORE = 1024
    YAW_RATE_IGNORE = 2048

    POSITION_ONLY = 3576
    VELOCITY_ONLY = 3527
    POSITION_VELOCITY = 3520


class OdidStatus(enum.IntEnum):
    UNDECLARED = 0
    GROUND = 1
    AIRBORNE = 2
    EMERGENCY = 3
    REMOTE_ID_SYSTEM_FAILURE = 4


class OdidIdType(enum.IntEnum):
    NONE = 0
    SERIAL_NUMBER = 1
    CAA_REGISTRATION_ID = 2
    UTM_ASSIGNED_UUID = 3
    SPECIFIC_SESSION_ID = 4


class OdidUaType(enum.IntEnum):
    NONE = 0
    AEROPLANE = 1
    HELICOPTER_OR_MULTIROTOR = 2


class OdidMessageType(enum.IntEnum):
    """ASTM F3411 message types (high nibble of byte 0)."""

    BASIC_ID = 0
    LOCATION = 1
    AUTHENTICATION = 2
    SELF_ID = 3
    SYSTEM = 4
    OPERATOR_ID = 5
    MESSAGE_PACK = 15


class RidsafeDetector(enum.IntEnum):
    FORCED = 0
    NIS = 1
    POWER_SPREAD = 2
    NIS_WINDOW = 3
    CUSUM = 4
    MLAT = 5
    MLAT_LONG = 6
    MLAT_CENSORED = 7


class RidTransport(enum.IntEnum):
    """RIDSAFE_RID_TRANSPORT: how a Remote ID frame reached its receiver."""

    UNKNOWN = 0
    SIMULATED = 1
    BLUETOOTH_LEGACY = 2
    BLUETOOTH_LONG_RANGE = 3
    WIFI_NAN = 4
    WIFI_BEACON = 5


class AlertState(enum.IntEnum):
    CLEARED = 0
    RAISED = 1


class RegionFlags(enum.IntFlag):
    NONE = 0
    DELETED = 1
    COASTING = 2
    ON_GROUND = 4
    UNCONFIRMED = 8
