"""Tests of ``ridsafe odid`` (ridsafe.tools.cli.odid_cmd).

The subcommand runs through the real ``ridsafe`` parser when every subcommand module imports, and
through a parser holding only ``odid`` otherwise (sibling subcommands may not exist yet).
"""

from __future__ import annotations

import argparse
import gzip
import importlib.util
import io
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from ridsafe.common.f3411 import encode
from ridsafe.tools.cli import (  # imports its subcommand modules only when called
    build_parser,
    odid_cmd,
)

VECTORS_PATH = Path(__file__).parents[2] / "data" / "odid_f3411_vectors.jsonl.gz"
LOCATION_HEX = "12317cfe4dc95367d69cdd02b90000610cbf090063781b0f00"  # vector line 1
SELF_ID = {"description_type": 0, "description": "Survey"}


def _full_cli_available() -> bool:
    modules = ("ridsafe.tools.cli.sim_cmd", "ridsafe.tools.cli.demo_cmd", "ridsafe.tools.cli")
    return all(importlib.util.find_spec(name) is not None for name in modules)


def _parser() -> argparse.ArgumentParser:
    if _full_cli_available():
        return build_parser()
    parser = argparse.ArgumentParser(prog="ridsafe")
    odid_cmd.register(parser.add_subparsers(dest="command"))
    return parser


def run(
    argv: list[str],
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    stdin: str = "",
) -> tuple[int, str, str]:
    """(exit code, stdout, stderr) of ``ridsafe *argv`` with ``stdin`` as its input."""
    monkeypatch.setattr(sys, "stdin", io.StringIO(stdin))
    args = _parser().parse_args(argv)
    code: int = args.func(args)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_encoding_the_whole_vector_file_reproduces_every_expected_hex(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    with gzip.open(VECTORS_PATH, "rt", encoding="utf-8") as lines:
        text = lines.read()
    cases = [json.loads(line) for line in text.splitlines()]
    code, out, err = run(["odid", "encode"], capsys, monkeypatch, stdin=text)
    assert code == 0
    results = [json.loads(line) for line in out.splitlines()]
    assert len(results) == len(cases) == 3000
    mismatches = [
        f"line {number}: {result} != {case['f3411_hex']}"
        for number, (case, result) in enumerate(zip(cases, results, strict=True), start=1)
        if result != {"message": case["message"], "f3411_hex": case["f3411_hex"]}
    ]
    assert not mismatches, "\n".join(mismatches[:20])
    rejected = [n for n, case in enumerate(cases, start=1) if case["f3411_hex"] is None]
    reported = [line for line in err.splitlines() if "rejected" in line]
    assert [int(line.split()[1].rstrip(":")) for line in reported] == rejected


def test_encode_reports_malformed_lines_by_number_and_keeps_going(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    good = json.dumps({"message": "OPEN_DRONE_ID_SELF_ID", "fields": SELF_ID, "note": "ignored"})
    stdin = "\n".join([good, "{not json", "", "[1, 2]", '{"message": "X"}', good]) + "\n"
    code, out, err = run(["odid", "encode"], capsys, monkeypatch, stdin=stdin)
    assert code == 1
    expected_hex = encode("OPEN_DRONE_ID_SELF_ID", SELF_ID).hex()
    results = [json.loads(line) for line in out.splitlines()]
    assert (
        results[0] == results[-1] == {"message": "OPEN_DRONE_ID_SELF_ID", "f3411_hex": expected_hex}
    )
    assert [r["line"] for r in results[1:-1]] == [2, 4, 5]  # line 3 is blank: skipped
    assert "missing key 'fields'" in results[3]["error"]
    assert [line.split(":")[0] for line in err.splitlines()] == ["line 2", "line 4", "line 5"]


def test_encode_exits_0_when_lines_are_well_formed_even_if_rejected(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    bad_type = {"message": "OPEN_DRONE_ID_SELF_ID", "fields": {**SELF_ID, "description_type": 300}}
    stdin = json.dumps(bad_type) + "\n"
    code, out, err = run(["odid", "encode"], capsys, monkeypatch, stdin=stdin)
    assert code == 0
    assert json.loads(out) == {"message": "OPEN_DRONE_ID_SELF_ID", "f3411_hex": None}
    assert err.startswith("line 1: rejected: OPEN_DRONE_ID_SELF_ID.description_type")


def test_decode_prints_the_fields_as_json(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    code, out, err = run(["odid", "decode", LOCATION_HEX], capsys, monkeypatch)
    assert (code, err) == (0, "")
    document = json.loads(out)
    assert document["message"] == "OPEN_DRONE_ID_LOCATION"
    assert document["fields"]["latitude"] == -697871415
    assert document["fields"]["direction"] == 12400


def test_decode_of_a_pack_lists_its_messages(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    self_id = encode("OPEN_DRONE_ID_SELF_ID", SELF_ID)
    pack = bytes([0xF2, 25, 2]) + bytes.fromhex(LOCATION_HEX) + self_id
    code, out, _ = run(["odid", "decode", pack.hex()], capsys, monkeypatch)
    assert code == 0
    document: dict[str, Any] = json.loads(out)
    assert document["fields"]["msg_pack_size"] == 2
    assert [part["message"] for part in document["contents"]] == [
        "OPEN_DRONE_ID_LOCATION",
        "OPEN_DRONE_ID_SELF_ID",
    ]
    assert document["contents"][1]["fields"]["description"] == "Survey"


@pytest.mark.parametrize(
    ("text", "words"),
    [("zz", "not hex"), ("1231", "25 bytes"), ("62" + "00" * 24, "unknown message type")],
)
def test_decode_of_bad_input_fails_with_a_message(
    text: str, words: str, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    code, out, err = run(["odid", "decode", text], capsys, monkeypatch)
    assert (code, out) == (1, "")
    assert words in err


def test_odid_without_an_action_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as caught:
        _parser().parse_args(["odid"])
    assert caught.value.code == 2
    assert "ACTION" in capsys.readouterr().err


@pytest.mark.skipif(not _full_cli_available(), reason="other ridsafe subcommands not written yet")
def test_the_installed_command_line_decodes() -> None:
    result = subprocess.run(
        [sys.executable, "-m", "ridsafe.tools.cli", "odid", "decode", LOCATION_HEX],
        capture_output=True,
        text=True,
        check=False,
        timeout=60,
    )
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout)["message"] == "OPEN_DRONE_ID_LOCATION"
