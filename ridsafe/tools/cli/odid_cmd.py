"""``ridsafe odid``: ASTM F3411 (Open Drone ID) encode and decode on the command line.

``ridsafe odid encode`` reads JSON lines ``{"message": "OPEN_DRONE_ID_LOCATION", "fields": {...}}``
(other keys ignored, blank lines skipped) on stdin and writes one JSON line per input line:
``{"message": ..., "f3411_hex": "<hex>"}``, with ``null`` where the reference encoder rejects
the fields (the reason goes to stderr). A line that is no JSON object with those keys gives
``{"line": N, "error": "..."}``; the exit code is 1 if any line did, else 0::

    zcat tests/data/odid_f3411_vectors.jsonl.gz | ridsafe odid encode

``ridsafe odid decode HEX`` prints one JSON object with the message name and its fields; for a
message pack also ``"contents"``, each contained message decoded. Exit code 1 on bad input.

``ridsafe odid capture FILE`` prints the Remote ID of a Wi-Fi or Bluetooth capture with RSSI
as JSON lines (``odid_capture``).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Iterable, Iterator
from typing import Any, TextIO

from ridsafe.common import f3411
from ridsafe.tools.cli.odid_capture import register_capture

_ENCODE_DESCRIPTION = (
    'Reads JSON lines {"message": "OPEN_DRONE_ID_...", "fields": {...}} on stdin and writes '
    '{"message": ..., "f3411_hex": "<hex>" or null} per line (null: the reference encoder '
    "rejects the fields; the reason goes to stderr). Exit code 1 if a line is malformed."
)


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``odid`` subcommand and its ``encode`` / ``decode`` actions."""
    parser = subparsers.add_parser(
        "odid",
        help="encode/decode ASTM F3411 Open Drone ID messages",
        description="Encode MAVLink OPEN_DRONE_ID_* field values to ASTM F3411 bytes and back.",
    )
    actions = parser.add_subparsers(dest="odid_action", metavar="ACTION", required=True)
    encode = actions.add_parser(
        "encode",
        help="JSON lines of MAVLink fields on stdin -> JSON lines with F3411 hex on stdout",
        description=_ENCODE_DESCRIPTION,
    )
    encode.set_defaults(func=run_encode)
    decode = actions.add_parser(
        "decode", help="print the MAVLink fields of one F3411 message (hex) as JSON"
    )
    decode.add_argument("hex", metavar="HEX", help="the message bytes in hex, e.g. 12317cfe...")
    decode.set_defaults(func=run_decode)
    register_capture(actions)


def _dumps(document: object) -> str:
    return json.dumps(document, separators=(",", ":"))


def _parse_case(line: str) -> tuple[str, dict[str, Any]]:
    """(message, fields) of one input line; ValueError says what is wrong with it."""
    try:
        case = json.loads(line)
    except json.JSONDecodeError as error:
        raise ValueError(f"not valid JSON: {error}") from None
    if not isinstance(case, dict):
        raise ValueError(f"expected a JSON object, got {type(case).__name__}")
    missing = [key for key in ("message", "fields") if key not in case]
    if missing:
        raise ValueError(f"missing key {missing[0]!r}")
    message, fields = case["message"], case["fields"]
    if not isinstance(message, str) or not isinstance(fields, dict):
        raise ValueError('"message" must be a string and "fields" an object')
    return message, fields


def encode_lines(lines: Iterable[str], errors: TextIO) -> Iterator[tuple[str, bool]]:
    """(output line, input was well-formed) for each non-blank input line."""
    for number, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        try:
            message, fields = _parse_case(line)
        except ValueError as error:
            print(f"line {number}: {error}", file=errors)
            yield _dumps({"line": number, "error": str(error)}), False
            continue
        try:
            encoded: str | None = f3411.encode(message, fields).hex()
        except f3411.F3411EncodeError as error:
            print(f"line {number}: rejected: {error}", file=errors)
            encoded = None
        yield _dumps({"message": message, "f3411_hex": encoded}), True


def run_encode(args: argparse.Namespace) -> int:
    all_well_formed = True
    for output, well_formed in encode_lines(sys.stdin, sys.stderr):
        print(output)
        all_well_formed &= well_formed
    return 0 if all_well_formed else 1


def run_decode(args: argparse.Namespace) -> int:
    text = str(args.hex).strip().removeprefix("0x")
    try:
        data = bytes.fromhex(text)
    except ValueError as error:
        print(f"ridsafe odid decode: not hex: {text!r} ({error})", file=sys.stderr)
        return 1
    try:
        message, fields = f3411.decode(data)
    except f3411.F3411DecodeError as error:
        print(f"ridsafe odid decode: {error}", file=sys.stderr)
        return 1
    document: dict[str, object] = {"message": message, "fields": fields}
    status = 0
    if f3411.message_type(data) is f3411.MessageType.MESSAGE_PACK:
        contents: list[dict[str, object]] = []
        for index, part in enumerate(f3411.split_pack(data)):
            try:
                contents.append(f3411.decode(part)._asdict())
            except f3411.F3411DecodeError as error:
                print(f"ridsafe odid decode: message {index} in the pack: {error}", file=sys.stderr)
                contents.append({"error": str(error)})
                status = 1
        document["contents"] = contents
    print(_dumps(document))
    return status
