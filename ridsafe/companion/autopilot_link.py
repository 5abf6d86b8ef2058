"""What the companion learns from its autopilot, and whether the autopilot is still there.

``AutopilotWatch`` reads the autopilot's messages (component 1 of our system; the shell has
refused the rest) into ``OwnTelemetry``: HEARTBEAT (mode, armed, state), GLOBAL_POSITION_INT,
LOCAL_POSITION_NED, HOME_POSITION, SYSTEM_TIME (each time-stamped message also updates the
autopilot clock estimate) and STATUSTEXT (logged). The link is up while a HEARTBEAT came
within ``autopilot_timeout_s``; losing and regaining it are events. COMMAND_ACK belongs to
the mission (``MissionDriver.on_ack``).

Two plausibility rules keep one forged datagram with the autopilot's ids (they reach a core
in-process, or over UDP before the runner has locked the link's peer) from steering the
companion; each refusal is counted and the real stream is unaffected:

- **clock**: a time-stamped message whose boot time would move the autopilot clock estimate
  more than ``MAX_CLOCK_STEP_S`` ahead of where it is (a real clock advances with arrival
  time; only a reboot moves it, and a reboot moves it back, which ``OwnTelemetry`` handles)
  is dropped whole (``clock_jumps``): log records are never stamped with such times;
- **disarm in flight**: a HEARTBEAT saying "disarmed" while fresh telemetry (a
  GLOBAL_POSITION_INT younger than ``FRESH_TELEMETRY_S``) puts the aircraft more than
  ``AIRBORNE_ALT_M`` above home is dropped (``implausible_disarm``): a multirotor that really
  disarms in the air falls, its telemetry says so within a second or two, and the next
  disarmed HEARTBEAT is then taken. A forged one therefore cannot end a mission in flight.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from ridsafe.common import messages as m
from ridsafe.companion.config import CompanionConfig
from ridsafe.companion.events import CompanionLog
from ridsafe.companion.telemetry import OwnTelemetry

__all__ = ["AutopilotCounters", "AutopilotWatch", "mode_name"]

#: How far ahead of its estimate (s) one message may move the autopilot clock.
MAX_CLOCK_STEP_S = 5.0
#: Above home by more than this (m), per fresh telemetry, the aircraft is flying.
AIRBORNE_ALT_M = 1.0
#: Telemetry younger than this (s, companion time) is fresh enough to judge a HEARTBEAT by.
FRESH_TELEMETRY_S = 2.0


@dataclass
class AutopilotCounters:
    unused_autopilot: int = 0  # decoded but not for us (e.g. GCS messages on this link)
    autopilot_lost: int = 0
    clock_jumps: int = 0  # time-stamped messages dropped: their clock was implausible
    implausible_disarm: int = 0  # "disarmed" HEARTBEATs dropped while telemetry says flying


def mode_name(custom_mode: int) -> str:
    try:
        return m.CopterMode(custom_mode).name
    except ValueError:
        return f"mode {custom_mode}"


class AutopilotWatch:
    """The autopilot's telemetry into ``own``; heartbeat watch (see the module docstring)."""

    def __init__(self, config: CompanionConfig, own: OwnTelemetry, log: CompanionLog) -> None:
        self.config = config
        self.own = own
        self.log = log
        self.counters = AutopilotCounters()
        self.lost = False

    def on_message(self, now_s: float, msg: m.Message) -> None:
        handler = _HANDLERS.get(type(msg))
        if handler is None:
            self.counters.unused_autopilot += 1
            return
        if not self._clock_plausible(now_s, msg):
            self.counters.clock_jumps += 1
            return
        handler(self, now_s, msg)

    def _clock_plausible(self, now_s: float, msg: m.Message) -> bool:
        time_boot_s = getattr(msg, "time_boot_s", None)
        offset = self.own.clock_offset_s
        if time_boot_s is None or offset is None:
            return True
        return bool(time_boot_s - now_s <= offset + MAX_CLOCK_STEP_S)

    def _flying(self, now_s: float) -> bool:
        gpi = self.own.gpi
        fresh = gpi is not None and now_s - self.own.gpi_s <= FRESH_TELEMETRY_S
        return fresh and gpi is not None and gpi.relative_alt_m > AIRBORNE_ALT_M

    def link_up(self, now_s: float) -> bool:
        beat = self.own.heartbeat_s
        return beat is not None and now_s - beat <= self.config.autopilot_timeout_s

    def watch(self, now_s: float) -> None:
        """Declare the link lost once the heartbeat is ``autopilot_timeout_s`` old."""
        beat = self.own.heartbeat_s
        if beat is not None and not self.link_up(now_s) and not self.lost:
            self.lost = True
            self.counters.autopilot_lost += 1
            self.log.event(now_s, "autopilot_lost", f"no heartbeat for {now_s - beat:.1f} s")

    def _on_heartbeat(self, now_s: float, msg: m.Message) -> None:
        assert isinstance(msg, m.Heartbeat)
        previous = self.own.heartbeat
        if previous is not None and previous.armed and not msg.armed and self._flying(now_s):
            self.counters.implausible_disarm += 1
            return
        self.own.heartbeat, self.own.heartbeat_s = msg, now_s
        if previous is None:
            self.log.event(now_s, "autopilot_seen", f"mode {mode_name(msg.custom_mode)}")
        elif (previous.custom_mode, previous.armed) != (msg.custom_mode, msg.armed):
            state = "armed" if msg.armed else "disarmed"
            self.log.event(now_s, "autopilot_state", f"{mode_name(msg.custom_mode)}, {state}")
        if self.lost:
            self.lost = False
            self.log.event(now_s, "autopilot_regained", "heartbeat is back")

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
            where = f"{msg.lat_deg:.7f}, {msg.lon_deg:.7f}, {msg.alt_msl_m:.1f} m"
            self.log.event(now_s, "home", where)
        self.own.set_home(msg)

    def _on_system_time(self, now_s: float, msg: m.Message) -> None:
        assert isinstance(msg, m.SystemTime)
        self.own.system_time, self.own.system_time_s = msg, now_s
        self.own.observe_clock(now_s, msg.time_boot_s)

    def _on_status_text(self, now_s: float, msg: m.Message) -> None:
        assert isinstance(msg, m.StatusText)
        self.log.event(now_s, "autopilot_text", msg.text, severity=msg.severity)


_HANDLERS: dict[type, Callable[[AutopilotWatch, float, m.Message], None]] = {
    m.Heartbeat: AutopilotWatch._on_heartbeat,
    m.GlobalPositionInt: AutopilotWatch._on_gpi,
    m.LocalPositionNed: AutopilotWatch._on_lpn,
    m.HomePosition: AutopilotWatch._on_home,
    m.SystemTime: AutopilotWatch._on_system_time,
    m.StatusText: AutopilotWatch._on_status_text,
}
