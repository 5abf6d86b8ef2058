"""``ridsafe odid capture FILE``: the Remote ID in a capture of real receivers, as JSON lines.

FILE is a pcap or pcapng of a monitor-mode Wi-Fi interface (radiotap header; beacons with the
F3411 vendor element, NAN service discovery frames) or a Bluetooth HCI log (btsnoop as
``btmon -w`` writes it, or pcap of HCI H4 / Linux monitor) with LE (extended) advertising
reports carrying service data 0xFFFA; the format is told by its first bytes. One JSON object
per F3411 message (a message pack gives one per message, with ``pack_index``)::

    {"t_unix_s": 1700000000.04, "t_s": 0.04, "record": 2, "transport": "WIFI_BEACON",
     "sender": "02:00:00:00:00:01", "rssi_dbm": -61, "channel": 6, "counter": 7,
     "message": "OPEN_DRONE_ID_LOCATION", "fields": {...}}

``t_s`` counts from the capture's first record (the time a companion replaying it hears the
frame); ``fields`` are MAVLink OPEN_DRONE_ID_* values, as ``ridsafe odid decode`` prints
them; a message that does not decode has ``"error"`` instead. Records that could not be read
are counted and named (file, record, byte offset) on stderr. Exit code 0: all read; 1: some
record or message skipped; 2: not a capture (or not readable).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Iterator
from typing import TextIO

from ridsafe.common import f3411
from ridsafe.common.capture import Capture, CapturedFrame, CaptureError, read_capture_file

__all__ = ["capture_lines", "register_capture", "run_capture"]


def register_capture(actions: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``capture`` to the ``odid`` actions."""
    capture = actions.add_parser(
        "capture",
        help="print the Remote ID of a Wi-Fi (pcap/pcapng) or Bluetooth (btsnoop) capture "
        "with RSSI as JSON lines",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    capture.add_argument("file", metavar="FILE", help="pcap, pcapng or btsnoop file")
    capture.set_defaults(func=run_capture)


def _messages(frame: bytes) -> Iterator[tuple[int | None, dict[str, object]]]:
    """(index in the pack or None, the decoded message or its error) of one frame."""
    try:
        is_pack = f3411.message_type(frame) is f3411.MessageType.MESSAGE_PACK
        parts = f3411.split_pack(frame) if is_pack else [frame]
    except f3411.F3411Error as error:
        yield None, {"error": f"frame {frame.hex()}: {error}"}
        return
    for index, part in enumerate(parts):
        where = index if is_pack else None
        try:
            name, fields = f3411.decode(part)
        except f3411.F3411Error as error:
            yield where, {"error": f"message {part.hex()}: {error}"}
            continue
        yield where, {"message": name, "fields": fields}


def _frame_documents(captured: CapturedFrame, first_ns: int) -> Iterator[dict[str, object]]:
    head: dict[str, object] = {
        "t_unix_s": captured.t_unix_ns / 1e9,
        "t_s": (captured.t_unix_ns - first_ns) / 1e9,
        "record": captured.record,
        "transport": captured.transport.name,
        "sender": captured.sender_mac,
        "rssi_dbm": captured.rssi_dbm,
        "channel": captured.channel,
        "counter": captured.counter,
    }
    for index, body in _messages(captured.frame):
        document = dict(head)
        if index is not None:
            document["pack_index"] = index
        document.update(body)
        yield document


def capture_lines(capture: Capture) -> Iterator[tuple[str, bool]]:
    """(JSON line, message decoded) for every message of every frame, in capture order."""
    first_ns = capture.first_t_unix_ns or 0
    for captured in capture.frames:
        for document in _frame_documents(captured, first_ns):
            yield json.dumps(document, separators=(",", ":")), "error" not in document


def _summary(capture: Capture, undecoded: int, errors: TextIO) -> None:
    for problem in capture.problems:
        print(problem, file=errors)
    skipped = ", ".join(f"{reason} {count}" for reason, count in sorted(capture.skipped.items()))
    print(
        f"{capture.source}: {capture.format.value}, {capture.records} records, "
        f"{len(capture.frames)} Remote ID frames, {undecoded} messages not decoded"
        + (f", skipped: {skipped}" if skipped else ""),
        file=errors,
    )


def run_capture(args: argparse.Namespace) -> int:
    try:
        capture = read_capture_file(args.file)
    except (CaptureError, OSError) as error:
        print(f"ridsafe odid capture: {error}", file=sys.stderr)
        return 2
    undecoded = 0
    for line, decoded in capture_lines(capture):
        print(line)
        undecoded += not decoded
    _summary(capture, undecoded, sys.stderr)
    return 1 if undecoded or capture.skipped else 0
