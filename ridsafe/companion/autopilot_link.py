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
- **clock reset**: a sample more than ``CLOCK_RESET_S`` behind the estimate (a reboot, to
  ``OwnTelemetry``) is taken only once ``RESET_CONFIRMATIONS`` samples in a row, at least
  ``RESET_SPACING_S`` apart in arrival time, agree on the new clock within
  ``RESET_AGREEMENT_S`` (a rebooted autopilot streams telemetry at several Hz, so a real
  reboot is confirmed within a fraction of a second); the others are dropped
  (``clock_jumps``);
- **disarm in flight**: a HEARTBEAT saying "disarmed" while any GLOBAL_POSITION_INT of the
  last ``FRESH_TELEMETRY_S`` put the aircraft more than ``AIRBORNE_ALT_M`` above home is
  dropped (``implausible_disarm``): a multirotor that really disarms in the air falls, its
  telemetry says so within a second or two, and the next disarmed HEARTBEAT is then taken;
  one forged low position among the real ones does not open the gate. A forged HEARTBEAT
  therefore cannot end a mission in flight.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from ridsafe.common import messages as m
from ridsafe.companion.config import CompanionConfig
from ridsafe.companion.events import CompanionLog
from ridsafe.companion.telemetry import CLOCK_RESET_S, OwnTelemetry

__all__ = ["AutopilotCounters", "AutopilotWatch", "mode_name"]

#: How far ahead of its estimate (s) one message may move the autopilot clock.
MAX_CLOCK_STEP_S = 5.0
#: Above home by more than this (m), per fresh telemetry, the aircraft is flying.
AIRBORNE_ALT_M = 1.0
#: Telemetry younger than this (s, companion time) is fresh enough to judge a HEARTBEAT by.
FRESH_TELEMETRY_S = 1.0
RESET_CONFIRMATIONS = 3
RESET_AGREEMENT_S = 0.5
RESET_SPACING_S = 0.05


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
        self._heights: deque[tuple[float, float]] = deque()  # (now_s, relative_alt_m)
        # a proposed clock reset: (clock offset, samples agreeing, time of the last counted)
        self._reset: tuple[float, int, float] | None = None

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
        sample = float(time_boot_s) - now_s
        if sample > offset + MAX_CLOCK_STEP_S:
            return False
        if sample >= offset - CLOCK_RESET_S:
            self._reset = None
            return True
        proposed, count, last_s = self._reset if self._reset is not None else (sample, 0, -1.0)
        if abs(sample - proposed) > RESET_AGREEMENT_S:
            count, last_s = 0, -1.0
        if now_s - last_s >= RESET_SPACING_S:  # a burst at one instant confirms nothing
            count, last_s = count + 1, now_s
        self._reset = (sample, count, last_s)
        return count >= RESET_CONFIRMATIONS

    def _flying(self, now_s: float) -> bool:
        heights = self._heights
        while heights and now_s - heights[0][0] > FRESH_TELEMETRY_S:
            heights.popleft()
        return any(alt > AIRBORNE_ALT_M for _, alt in heights)

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
        self._heights.append((now_s, msg.relative_alt_m))
        if len(self._heights) > 1000:  # a burst at one instant: bounded
            self._heights.popleft()
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
