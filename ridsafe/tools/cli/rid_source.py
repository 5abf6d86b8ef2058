"""``--rid-source``: where a companion's heard Remote ID frames come from.

- ``transponder`` (default): the RID transponder on the autopilot link (the sim's radio, or
  a real transponder speaking the ridsafe dialect).
- ``capture:FILE``: a capture of real receivers, its format told by its first bytes (pcap
  or pcapng of a monitor-mode Wi-Fi interface with radiotap; btsnoop of an HCI log; pcap of
  HCI H4 / Linux monitor). ``pcap:FILE``, ``pcapng:FILE`` and ``btsnoop:FILE`` are the same,
  and also check that the file is of that format.

A capture is replayed relative to its first record: a frame captured ``d`` s after it is
heard at ``--rid-start-s`` + ``d`` on the companion's clock (the companion's clock starts at
0 when it starts, or at ``--t0-unix``). The transponder's own frames are then ignored.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

from ridsafe.common.capture import CaptureError, CaptureFormat, read_capture_file
from ridsafe.companion.receivers import CaptureReceiver, RidReceiver, TransponderReceiver

__all__ = ["RidSource", "make_receiver", "parse_rid_source"]

logger = logging.getLogger(__name__)

TRANSPONDER = "transponder"
_CAPTURE_KINDS: dict[str, CaptureFormat | None] = {
    "capture": None,
    "pcap": CaptureFormat.PCAP,
    "pcapng": CaptureFormat.PCAPNG,
    "btsnoop": CaptureFormat.BTSNOOP,
}


@dataclass(frozen=True)
class RidSource:
    """A parsed ``--rid-source``: the transponder (``path`` None) or a capture file."""

    path: Path | None = None
    expected_format: CaptureFormat | None = None


def parse_rid_source(text: str) -> RidSource:
    if text == TRANSPONDER:
        return RidSource()
    kind, sep, path = text.partition(":")
    if not sep or kind not in _CAPTURE_KINDS or not path:
        kinds = ", ".join(f"{k}:FILE" for k in _CAPTURE_KINDS)
        raise ValueError(f"--rid-source {text!r}: expected {TRANSPONDER} or one of {kinds}")
    return RidSource(Path(path), _CAPTURE_KINDS[kind])


def make_receiver(source: RidSource, start_s: float, own_serial: str = "") -> RidReceiver:
    """The receiver of ``source`` (a capture is read whole now; ``CaptureError`` / OSError
    if it cannot be); frames from ``own_serial`` in a capture are the aircraft's own."""
    if source.path is None:
        return TransponderReceiver()
    capture = read_capture_file(source.path)
    if source.expected_format is not None and capture.format is not source.expected_format:
        raise CaptureError(
            str(source.path),
            0,
            f"a {source.expected_format.value} file was named, this is {capture.format.value}",
        )
    receiver = CaptureReceiver(capture, start_s, own_serial.encode("ascii"))
    skipped = sum(capture.skipped.values())
    logger.info(
        "%s: %d records, %d Remote ID frames, %d skipped",
        source.path,
        capture.records,
        len(capture.frames),
        skipped,
    )
    return receiver
