"""The sim autopilot's parameters: ArduCopter names, units and defaults, as a table.

``PARAMS`` lists every parameter the sim exposes over the parameter protocol
(PARAM_REQUEST_LIST / PARAM_REQUEST_READ / PARAM_SET -> PARAM_VALUE). A row either drives
behaviour (the autopilot reads it through ``ParamStore`` every time it needs it, so a
PARAM_SET takes effect at once) or is carried for ground stations that expect it (the
``WPNAV_*`` climb/descent speeds and ``FENCE_MARGIN``: the sim's controller limits apply;
``used`` False says so). The geofence (``FENCE_*``) is :mod:`ridsafe.sim_backend.fence`,
``WPNAV_SPEED`` :mod:`ridsafe.sim_backend.wpnav`.

Units are ArduCopter's (RTL_ALT in cm, RTL_SPEED in cm/s, ...); defaults that the sim's
``AutopilotConfig`` sets come from it, so a default run behaves as before the table existed.
``SIM_OFB_LOSS_T`` / ``SIM_OFB_LOSS_ACT`` are the sim's own (like SITL's ``SIM_*``): the
companion-loss failsafe (see :mod:`ridsafe.sim_backend.autopilot`). ``SR0_*`` are the stream
rates (Hz) of the ground-station link, ``SR1_*`` of the companion link; a PARAM_SET of one
sets that stream group's rate on that link, as REQUEST_DATA_STREAM does.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ridsafe.common import protocol_messages as pm
from ridsafe.common.protocol_messages import ParamType

if TYPE_CHECKING:  # the autopilot imports this table
    from ridsafe.sim_backend.autopilot import AutopilotConfig

MAX_NAME_LEN = 16


class FailsafeAction(enum.IntEnum):
    """What the companion-loss failsafe does (``SIM_OFB_LOSS_ACT``)."""

    HOLD = 0
    LAND = 1
    RTL = 2


STREAM_GROUPS = ("RAW_SENS", "EXT_STAT", "RC_CHAN", "POSITION", "EXTRA1", "EXTRA2", "EXTRA3")


@dataclass(frozen=True)
class ParamSpec:
    name: str
    default: Callable[[AutopilotConfig], float]
    param_type: ParamType = ParamType.REAL32
    low: float = -math.inf
    high: float = math.inf
    used: bool = True


def _fixed(value: float) -> Callable[[AutopilotConfig], float]:
    return lambda config: value


def _int(name: str, value: float, low: float, high: float, used: bool = True) -> ParamSpec:
    return ParamSpec(name, _fixed(value), ParamType.INT8 if high < 128 else ParamType.INT16,
                     low, high, used)  # fmt: skip


PARAMS: tuple[ParamSpec, ...] = (
    _int("ARMING_CHECK", 1, 0, 0x7FFF),
    ParamSpec("DISARM_DELAY", lambda c: c.disarm_delay_s, ParamType.INT8, 0, 127),
    ParamSpec("GUID_TIMEOUT", lambda c: c.failsafe_timeout_s, low=0.1, high=5.0),
    ParamSpec("LAND_SPEED", lambda c: c.land_speed_m_s * 100.0, low=30, high=200),
    ParamSpec("LAND_SPEED_HIGH", lambda c: c.land_speed_high_m_s * 100.0, low=0, high=2500),
    ParamSpec("LAND_ALT_LOW", lambda c: c.land_final_alt_m * 100.0, low=100, high=10000),
    ParamSpec("RTL_ALT", lambda c: c.rtl_alt_m * 100.0, low=30, high=300000),
    ParamSpec("RTL_SPEED", lambda c: c.rtl_speed_m_s * 100.0, low=0, high=2000),
    ParamSpec("WPNAV_SPEED", _fixed(1000.0), low=20, high=2000),
    ParamSpec("WPNAV_SPEED_UP", _fixed(250.0), low=10, high=1000, used=False),
    ParamSpec("WPNAV_SPEED_DN", _fixed(150.0), low=10, high=500, used=False),
    ParamSpec("WPNAV_RADIUS", _fixed(200.0), low=5, high=1000),
    ParamSpec("SIM_OFB_LOSS_T", lambda c: c.companion_loss_timeout_s, low=0.0, high=3600.0),
    ParamSpec("SIM_OFB_LOSS_ACT", lambda c: float(c.companion_loss_action), ParamType.INT8, 0, 2),
    ParamSpec("SIM_PREARM_T", lambda c: c.prearm_delay_s, low=0.0, high=3600.0),
    _int("FENCE_ENABLE", 0, 0, 1),
    _int("FENCE_TYPE", 7, 0, 15),
    _int("FENCE_ACTION", 1, 0, 5),
    ParamSpec("FENCE_ALT_MAX", _fixed(100.0), low=10, high=1000),
    ParamSpec("FENCE_RADIUS", _fixed(300.0), low=30, high=10000),
    ParamSpec("FENCE_MARGIN", _fixed(2.0), low=1, high=10, used=False),
    _int("FS_GCS_ENABLE", 0, 0, 7, used=False),
    _int("SYSID_THISMAV", 1, 1, 255, used=False),
    *(
        ParamSpec(f"SR{port}_{group}", _fixed(0.0), ParamType.INT16, 0, 400)
        for port in (0, 1)
        for group in STREAM_GROUPS
    ),
)

_BY_NAME = {spec.name: i for i, spec in enumerate(PARAMS)}
assert all(len(spec.name) <= MAX_NAME_LEN for spec in PARAMS)


class ParamStore:
    """One autopilot's parameter values, in table order."""

    def __init__(self, config: AutopilotConfig, sysid: int) -> None:
        self.values = [float(spec.default(config)) for spec in PARAMS]
        self.values[_BY_NAME["SYSID_THISMAV"]] = float(sysid)
        self.defaults = list(self.values)  # what the parameter file's defaults say

    def __len__(self) -> int:
        return len(PARAMS)

    def get(self, name: str) -> float:
        return self.values[_BY_NAME[name]]

    def index(self, name: str) -> int | None:
        return _BY_NAME.get(name)

    def set(self, name: str, value: float) -> bool:
        """Set ``name`` to ``value`` clipped into its range; False if unknown or not finite."""
        index = _BY_NAME.get(name)
        if index is None or not math.isfinite(value):
            return False
        spec = PARAMS[index]
        clipped = min(max(value, spec.low), spec.high)
        if spec.param_type is not ParamType.REAL32:
            clipped = float(round(clipped))
        self.values[index] = clipped
        return True

    def value_message(self, index: int) -> pm.ParamValue:
        spec = PARAMS[index]
        return pm.ParamValue(
            spec.name, self.values[index], int(spec.param_type), len(PARAMS), index
        )
