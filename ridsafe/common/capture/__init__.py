"""Remote ID from captures of real receivers: Wi-Fi monitor mode and Bluetooth LE HCI logs.

``read_capture(data, source)`` turns a whole capture file (pcap, pcapng or btsnoop, told
apart by their magic) into ``CapturedFrame``s: each F3411 frame (one message or a message
pack) with the capture time of its packet, its RSSI (radiotap dBm antenna signal; the HCI
advertising report's RSSI), transport, sender address and message counter. Pure: bytes in,
frames out; the caller reads the file. ``heard_frames`` makes the ``HeardRidFrame``s a
companion hears from them (``companion.receivers.CaptureReceiver``).

Bad input is the rule, not the exception: a file that is no capture at all raises
``CaptureError`` naming the file and byte offset; a record that is cut short, hostile or
unreadable is counted under a reason in ``Capture.skipped`` and described (file, record
number, byte offset) in ``Capture.problems``, and reading goes on where it can.

Modules: ``containers`` (file formats -> records), ``radiotap``, ``wifi`` (beacon vendor
element, NAN service discovery), ``bluetooth`` (HCI LE advertising reports, service data
0xFFFA), ``frames`` (records -> frames, and frames -> heard frames).
"""

from ridsafe.common.capture.containers import CaptureError, CaptureFormat
from ridsafe.common.capture.frames import (
    Capture,
    CapturedFrame,
    heard_frames,
    read_capture,
    read_capture_file,
    sender_names,
)

__all__ = [
    "Capture",
    "CaptureError",
    "CaptureFormat",
    "CapturedFrame",
    "heard_frames",
    "read_capture",
    "read_capture_file",
    "sender_names",
]
