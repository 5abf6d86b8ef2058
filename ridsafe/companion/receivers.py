"""Where the frames a companion hears come from: the ``RidReceiver`` interface.

A receiver hands the companion whole heard frames (``common.heard.HeardRidFrame``: F3411
bytes, RSSI, receive time on the companion's clock, sender, transport); nothing above this
interface knows which radio it is. Two receivers:

- ``TransponderReceiver``: the RID transponder on the autopilot link (the sim's, or a real
  one that speaks the ridsafe dialect) sends one RIDSAFE_RID_FRAME per frame it hears; the
  companion stamps it with its arrival time.
- ``RecordedFrames``: frames recorded earlier (a test, a log), released when the
  companion's clock reaches their receive time.
- ``CaptureReceiver``: a capture of real receivers (monitor-mode Wi-Fi pcap/pcapng with
  radiotap RSSI, Bluetooth LE HCI btsnoop; read by ``common.capture``), replayed relative
  to the capture's first record: a frame captured ``d`` s after it is heard at
  ``start_s + d`` on the companion's clock. Its counters include what the capture skipped.

A new source (a live Wi-Fi / Bluetooth capture) is one more class with these three methods,
passed to ``Companion(receiver=...)``.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable
from dataclasses import asdict, dataclass
from typing import Protocol

from ridsafe.common import messages as m
from ridsafe.common.capture import Capture, heard_frames
from ridsafe.common.heard import HeardRidFrame

__all__ = ["CaptureReceiver", "RecordedFrames", "RidReceiver", "TransponderReceiver"]


class RidReceiver(Protocol):
    """Heard Remote ID frames with their signal strength, whatever the radio."""

    name: str

    def on_transponder(self, now_s: float, message: m.Message) -> None:
        """A message from the RID transponder component (receivers that use none ignore
        it)."""
        ...

    def poll(self, now_s: float) -> list[HeardRidFrame]:
        """Frames heard since the last call, oldest first."""
        ...

    def counters(self) -> dict[str, int]: ...


@dataclass
class TransponderCounters:
    frames: int = 0
    other: int = 0  # transponder messages that are not heard frames (none expected)


class TransponderReceiver:
    """Heard frames from the RID transponder's RIDSAFE_RID_FRAME messages, stamped on
    arrival (the transponder sends each as soon as it hears it)."""

    name = "transponder"

    def __init__(self) -> None:
        self.stats = TransponderCounters()
        self._heard: list[HeardRidFrame] = []

    def on_transponder(self, now_s: float, message: m.Message) -> None:
        if isinstance(message, m.RidFrameReport):
            self.stats.frames += 1
            self._heard.append(HeardRidFrame(now_s, message))
        elif type(message) is m.RidFrameReports:  # a run of them, decoded together
            self.stats.frames += len(message)
            self._heard.extend([HeardRidFrame(now_s, report) for report in message.reports])
        else:
            self.stats.other += 1

    def poll(self, now_s: float) -> list[HeardRidFrame]:
        out, self._heard = self._heard, []
        return out

    def counters(self) -> dict[str, int]:
        return dict(asdict(self.stats))


class RecordedFrames:
    """Frames recorded before the run (receive times on the companion's clock), released
    once ``now_s`` reaches them; the transponder's messages are ignored."""

    name = "recorded"

    def __init__(self, frames: Iterable[HeardRidFrame]) -> None:
        self._waiting = deque(sorted(frames, key=lambda heard: heard.rx_t_s))
        self.released = 0

    def on_transponder(self, now_s: float, message: m.Message) -> None:
        return None

    def poll(self, now_s: float) -> list[HeardRidFrame]:
        out: list[HeardRidFrame] = []
        while self._waiting and self._waiting[0].rx_t_s <= now_s:
            out.append(self._waiting.popleft())
        self.released += len(out)
        return out

    def counters(self) -> dict[str, int]:
        return {"released": self.released, "waiting": len(self._waiting)}


class CaptureReceiver(RecordedFrames):
    """The frames of a capture file (``common.capture.read_capture``), heard at ``start_s``
    plus their time after the capture's first record. Frames whose sender is ``own_sender_id``
    (the aircraft's own broadcasts, which a real receiver beside its transponder captures
    too; the sim's radio never delivers them) are left out and counted."""

    name = "capture"

    def __init__(self, capture: Capture, start_s: float = 0.0, own_sender_id: bytes = b"") -> None:
        heard = heard_frames(capture, start_s)
        others = [frame for frame in heard if not own_sender_id or frame.sender_id != own_sender_id]
        super().__init__(others)
        self.source = capture.source
        self._skipped = {f"skipped_{reason}": count for reason, count in capture.skipped.items()}
        if len(others) < len(heard):
            self._skipped["own_frames"] = len(heard) - len(others)

    def counters(self) -> dict[str, int]:
        return {**super().counters(), **self._skipped}
