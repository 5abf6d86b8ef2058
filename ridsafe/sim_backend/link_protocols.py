"""What one simulated autopilot answers on one link besides commands, sans I/O: the parameter
protocol, TIMESYNC, REQUEST_DATA_STREAM and the mission protocol (ArduCopter's behaviour).

- PARAM_REQUEST_LIST -> every PARAM_VALUE in table order (:mod:`.param_table`);
  PARAM_REQUEST_READ (by name, or by index when ``param_index`` >= 0) -> one PARAM_VALUE,
  nothing for an unknown name (as ArduPilot); PARAM_SET -> the stored value as PARAM_VALUE
  (clipped into range), nothing for an unknown name. A ``SRn_*`` set on the link it names
  sets that stream group's rate there.
- REQUEST_DATA_STREAM: ArduCopter's stream groups (``STREAM_GROUPS``) -> message ids; a rate
  of 0 or ``start`` False stops the group.
- TIMESYNC with ``tc1`` 0 -> TIMESYNC(tc1 = the vehicle's clock in ns, ts1 echoed).
- FILE_TRANSFER_PROTOCOL: the parameter file over MAVLink FTP (:mod:`.ftp`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ridsafe.common import protocol_messages as pm
from ridsafe.common.messages import MavResult
from ridsafe.sim_backend import telemetry as t
from ridsafe.sim_backend.autopilot import Autopilot, CommandContext
from ridsafe.sim_backend.ftp import FtpServer
from ridsafe.sim_backend.mission_protocol import MISSION_MESSAGES, MissionTransfer
from ridsafe.sim_backend.param_table import STREAM_GROUPS
from ridsafe.sim_backend.telemetry import TelemetrySchedule

# MAV_DATA_STREAM id -> (SRx_ suffix, message ids), after ArduCopter's GCS_MAVLink streams.
DATA_STREAMS: dict[int, tuple[str, tuple[int, ...]]] = {
    1: ("RAW_SENS", ()),
    2: ("EXT_STAT", (t.SYS_STATUS, t.GPS_RAW_INT, t.MISSION_CURRENT)),
    3: ("RC_CHAN", (t.RC_CHANNELS,)),
    6: ("POSITION", (t.GLOBAL_POSITION_INT, t.LOCAL_POSITION_NED)),
    10: ("EXTRA1", (t.ATTITUDE,)),
    11: ("EXTRA2", (t.VFR_HUD,)),
    12: ("EXTRA3", (t.SYSTEM_TIME, t.BATTERY_STATUS, t.EXTENDED_SYS_STATE)),
}
ALL_STREAMS = 0
_BY_SUFFIX = {suffix: ids for suffix, ids in DATA_STREAMS.values()}
assert set(_BY_SUFFIX) == set(STREAM_GROUPS)

PARAM_MESSAGES = (pm.ParamRequestList, pm.ParamRequestRead, pm.ParamSet)
LINK_MESSAGES = (*PARAM_MESSAGES, pm.RequestDataStream, *MISSION_MESSAGES, pm.FileTransferProtocol)


def set_stream_rate(schedule: TelemetrySchedule, msg_ids: tuple[int, ...], rate_hz: float) -> None:
    for msg_id in msg_ids:
        schedule.set_interval(msg_id, 1e6 / rate_hz if rate_hz > 0 else -1.0)


@dataclass
class LinkResponder:
    """One vehicle's answers on one link; ``serial`` is the link's SRx number."""

    sysid: int
    serial: int
    missions: MissionTransfer = field(init=False)
    ftp: FtpServer = field(default_factory=FtpServer)

    def __post_init__(self) -> None:
        self.missions = MissionTransfer(self.sysid)

    def handle(
        self,
        msg: pm.ProtocolMessage,
        autopilot: Autopilot,
        schedule: TelemetrySchedule,
        ctx: CommandContext,
        client: tuple[int, int],
    ) -> list[pm.ProtocolMessage]:
        if isinstance(msg, PARAM_MESSAGES):
            return self._param(msg, autopilot, schedule)
        if isinstance(msg, pm.RequestDataStream):
            self._data_stream(msg, schedule)
            return []
        if isinstance(msg, pm.FileTransferProtocol):
            return list(self.ftp.handle(msg, autopilot.params, client))
        if isinstance(msg, MISSION_MESSAGES):
            home = autopilot.home.home_geodetic
            out, target = self.missions.handle(
                msg, autopilot.missions, (home.lat_deg, home.lon_deg, 0.0), client
            )
            if target is not None:
                outcome = autopilot.go_to_global(
                    target.lat_deg, target.lon_deg, target.alt_m, target.frame, ctx
                )
                accepted = outcome.result is MavResult.ACCEPTED
                result = pm.MissionResult.ACCEPTED if accepted else pm.MissionResult.ERROR
                out.append(pm.MissionAck(*client, result, pm.MissionType.MISSION))
            return out
        return []

    def _param(
        self,
        msg: pm.ParamRequestList | pm.ParamRequestRead | pm.ParamSet,
        autopilot: Autopilot,
        schedule: TelemetrySchedule,
    ) -> list[pm.ProtocolMessage]:
        params = autopilot.params
        if isinstance(msg, pm.ParamRequestList):
            return [params.value_message(i) for i in range(len(params))]
        if isinstance(msg, pm.ParamRequestRead):
            index = msg.param_index if msg.param_index >= 0 else params.index(msg.param_id)
            if index is None or not 0 <= index < len(params):
                return []
            return [params.value_message(index)]
        if not params.set(msg.param_id, msg.value):
            return []
        self._apply_stream_param(msg.param_id, params.get(msg.param_id), schedule)
        index = params.index(msg.param_id)
        assert index is not None
        return [params.value_message(index)]

    def _apply_stream_param(self, name: str, rate_hz: float, schedule: TelemetrySchedule) -> None:
        prefix = f"SR{self.serial}_"
        if name.startswith(prefix):
            set_stream_rate(schedule, _BY_SUFFIX[name[len(prefix) :]], rate_hz)

    def _data_stream(self, msg: pm.RequestDataStream, schedule: TelemetrySchedule) -> None:
        ids = DATA_STREAMS if msg.stream_id == ALL_STREAMS else {}
        if msg.stream_id in DATA_STREAMS:
            ids = {msg.stream_id: DATA_STREAMS[msg.stream_id]}
        rate_hz = float(msg.rate_hz) if msg.start else 0.0
        for _suffix, msg_ids in ids.values():
            set_stream_rate(schedule, msg_ids, rate_hz)


def timesync_answer(msg: pm.Timesync, now_s: float) -> pm.Timesync | None:
    """ArduPilot answers a TIMESYNC request (tc1 0) with its own clock in tc1."""
    if msg.tc1_ns != 0:
        return None
    return pm.Timesync(round(now_s * 1e9), msg.ts1_ns)
