"""``ridsafe odid capture FILE`` and the companion's ``--rid-source``, through the real parser.

Oracle: captures built around reference encodings (tests/common/capture/builders.py); each
printed message must decode to what ``ridsafe.common.f3411`` says those bytes hold.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from ridsafe.common import codec, f3411, rid
from ridsafe.common.capture import CaptureError, CaptureFormat
from ridsafe.companion.receivers import CaptureReceiver, TransponderReceiver
from ridsafe.tools.cli import build_parser
from ridsafe.tools.cli.rid_source import RidSource, make_receiver, parse_rid_source
from tests.common.capture import builders as b

LOCATIONS = b.reference_messages("OPEN_DRONE_ID_LOCATION", 2)
BASIC = b.reference_messages("OPEN_DRONE_ID_BASIC_ID", 1)[0]


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, list[str], str]:
    args = build_parser().parse_args(argv)
    code: int = args.func(args)
    captured = capsys.readouterr()
    return code, captured.out.splitlines(), captured.err


def _wifi_capture(path: Path) -> Path:
    pack = b.location_pack(LOCATIONS[0], BASIC)
    items = [
        b.Timed(0.0, b.plain_beacon("00:11:22:33:44:55", -40)),
        b.Timed(0.5, b.beacon("02:00:00:00:00:01", 7, pack, -61)),
    ]
    return b.write_pcapng(path, items, b.LINKTYPE_RADIOTAP)


def test_a_wifi_capture_prints_one_line_per_message_of_the_pack_with_rssi(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, lines, err = _run(["odid", "capture", str(_wifi_capture(tmp_path / "w.pcapng"))], capsys)
    assert code == 0
    documents = [json.loads(line) for line in lines]
    assert [d["pack_index"] for d in documents] == [0, 1]
    for document, part in zip(documents, [BASIC, LOCATIONS[0]], strict=True):
        name, fields = f3411.decode(part)
        assert document["message"] == name and document["fields"] == json.loads(json.dumps(fields))
        assert document["rssi_dbm"] == -61 and document["transport"] == "WIFI_BEACON"
        assert document["sender"] == "02:00:00:00:00:01" and document["record"] == 2
        assert document["t_s"] == 0.5 and document["t_unix_s"] == b.EPOCH_S + 0.5
        assert document["channel"] == 6 and document["counter"] == 7
    assert "2 records, 1 Remote ID frames" in err


def test_a_bluetooth_log_prints_its_advertisements_with_rssi(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    items = [b.Timed(0.25, b.legacy_report_event("c0:00:00:00:00:09", 3, LOCATIONS[1], -83))]
    path = b.write_btsnoop(tmp_path / "hci.btsnoop", items, b.BTSNOOP_MONITOR)
    code, lines, _err = _run(["odid", "capture", str(path)], capsys)
    (document,) = [json.loads(line) for line in lines]
    assert code == 0 and "pack_index" not in document
    assert (document["transport"], document["sender"], document["rssi_dbm"]) == (
        "BLUETOOTH_LEGACY",
        "c0:00:00:00:00:09",
        -83,
    )
    assert document["message"] == "OPEN_DRONE_ID_LOCATION" and document["t_s"] == 0.0


def test_skipped_records_are_named_on_stderr_and_exit_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _wifi_capture(tmp_path / "w.pcapng")
    cut = tmp_path / "cut.pcapng"
    cut.write_bytes(path.read_bytes()[:-6])
    code, lines, err = _run(["odid", "capture", str(cut)], capsys)
    assert code == 1 and lines == []
    assert f"{cut}: record 2 (byte " in err and "truncated" in err


def test_a_file_that_is_no_capture_exits_2_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "notes.txt"
    path.write_text("hello")
    code, lines, err = _run(["odid", "capture", str(path)], capsys)
    assert (code, lines) == (2, [])
    assert f"ridsafe odid capture: {path}: byte 0: not a pcap" in err


def test_rid_sources_parse_to_the_transponder_or_a_capture_file() -> None:
    assert parse_rid_source("transponder") == RidSource()
    assert parse_rid_source("capture:a/b.pcap") == RidSource(Path("a/b.pcap"))
    assert parse_rid_source("btsnoop:x") == RidSource(Path("x"), CaptureFormat.BTSNOOP)
    for bad in ("pcap", "pcap:", "wifi:x.pcap", "sim"):
        with pytest.raises(ValueError, match="--rid-source"):
            parse_rid_source(bad)


def test_a_capture_source_checks_the_format_it_names(tmp_path: Path) -> None:
    path = _wifi_capture(tmp_path / "w.pcapng")
    receiver = make_receiver(parse_rid_source(f"pcapng:{path}"), start_s=2.0)
    assert isinstance(receiver, CaptureReceiver)
    assert [h.rx_t_s for h in receiver.poll(10.0)] == [2.5]
    assert isinstance(make_receiver(RidSource(), 0.0), TransponderReceiver)
    with pytest.raises(CaptureError, match="a btsnoop file was named, this is pcapng"):
        make_receiver(parse_rid_source(f"btsnoop:{path}"), 0.0)


def test_the_companion_refuses_a_capture_for_several_vehicles(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _wifi_capture(tmp_path / "w.pcapng")
    code, _lines, err = _run(
        ["companion", "--vehicle", "1-2", "--rid-source", f"capture:{path}"], capsys
    )
    assert code == 2 and "single --vehicle" in err


@pytest.mark.udp
def test_a_companion_fed_by_a_capture_hears_its_frames_through_the_real_command(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # No autopilot answers (ports nobody listens on): the companion has no own position, so
    # each LOCATION heard is counted under no_own_position -- but heard from the capture.
    path = _wifi_capture(tmp_path / "w.pcapng")
    argv = ["companion", "--vehicle", "1", "--rid-source", f"capture:{path}", "--speed", "10"]
    argv += ["--duration", "2", "--autopilot", "udpout:127.0.0.1:47999"]
    code, lines, _err = _run([*argv, "--gcs", "udpout:127.0.0.1:47998"], capsys)
    counters = [line for line in lines if "counters" in line][-1]
    assert code == 0
    assert "'receiver.released': 1" in counters and "'observations.heard': 1" in counters


def test_the_aircrafts_own_broadcasts_in_a_capture_are_left_out_and_counted(
    tmp_path: Path,
) -> None:
    serial = "RSAF800000001"
    own_basic = f3411.encode(*codec.odid_fields(rid.basic_id(serial)))
    items = [
        b.Timed(
            0.0, b.beacon("02:00:00:00:00:01", 1, b.location_pack(LOCATIONS[0], own_basic), -20)
        ),
        b.Timed(0.1, b.beacon("02:00:00:00:00:02", 2, b.location_pack(LOCATIONS[1]), -70)),
    ]
    path = b.write_pcap(tmp_path / "own.pcap", items, b.LINKTYPE_RADIOTAP)
    receiver = make_receiver(parse_rid_source(f"pcap:{path}"), 0.0, serial)
    heard = receiver.poll(1.0)
    assert [(h.sender_id, h.rssi_dbm) for h in heard] == [(b"02:00:00:00:00:02", -70.0)]
    assert receiver.counters() == {"released": 1, "waiting": 0, "own_frames": 1}


def test_a_reader_that_leaves_early_ends_the_command_quietly(tmp_path: Path) -> None:
    """``ridsafe odid capture FILE | head -1``: no BrokenPipeError traceback, exit 141 (as a
    shell reports SIGPIPE), through a real pipe."""
    pack = b.location_pack(LOCATIONS[0], BASIC)
    beacons = [bytes(b.beacon("02:00:00:00:00:01", counter, pack, -61)) for counter in range(256)]
    items = [b.Timed(0.01 * i, beacons[i % 256]) for i in range(4000)]  # megabytes of lines
    capture = b.write_pcapng(tmp_path / "many.pcapng", items, b.LINKTYPE_RADIOTAP)
    argv = [sys.executable, "-m", "ridsafe.tools.cli", "odid", "capture", str(capture)]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout is not None and proc.stderr is not None
    first = proc.stdout.readline()
    proc.stdout.close()  # the reader leaves, as `head -1` does
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 141, err
    assert json.loads(first)["message"] == "OPEN_DRONE_ID_BASIC_ID"
    assert "Traceback" not in err
