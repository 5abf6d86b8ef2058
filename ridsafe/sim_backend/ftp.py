"""MAVLink FTP (FILE_TRANSFER_PROTOCOL) as ArduCopter offers it to ground stations, sans I/O:
the parameter file, so that a station's FTP parameter download works against the sim.

The sim's virtual file system holds one file, as ArduPilot's ``@PARAM`` file system does:

- ``/`` lists the directory ``@PARAM``; ``@PARAM`` lists ``param.pck`` with its size.
- ``@PARAM/param.pck`` is every parameter of the table in ArduPilot's packed format
  (:func:`pack_params`); ``@PARAM/param.pck?withdefaults=1`` also carries the defaults.

Operations: ListDirectory, OpenFileRO, ReadFile, BurstReadFile, TerminateSession,
ResetSessions, each answered with an ACK (``req_opcode`` the request's, ``seq`` the request's
+ 1) or a NAK whose first data byte is the error (FileNotFound, EOF, InvalidSession,
NoSessionsAvailable, ...). Everything that writes (CreateFile, WriteFile, RemoveFile, ...) is
NAKed FileProtected on ``@PARAM`` paths and UnknownCommand otherwise: the sim has no card.

Packet layout (the FILE_TRANSFER_PROTOCOL payload, 251 bytes): seq u16, session u8, opcode u8,
size u8, req_opcode u8, burst_complete u8, padding u8, offset u32, data[239], little-endian.
"""

from __future__ import annotations

import enum
import struct
from dataclasses import dataclass, field

from ridsafe.common import protocol_messages as pm
from ridsafe.common.protocol_messages import ParamType
from ridsafe.sim_backend.param_table import PARAMS, ParamStore

__all__ = ["FtpError", "FtpOp", "FtpServer", "pack_params"]

HEADER = struct.Struct("<HBBBBBBI")
MAX_DATA = 239
MAX_SESSIONS = 4
PARAM_DIR = "@PARAM"
PARAM_FILE = "param.pck"
WITH_DEFAULTS = "withdefaults=1"

PCK_MAGIC = 0x671B
PCK_MAGIC_WITH_DEFAULTS = 0x671C
# MAV_PARAM_TYPE -> (packed type code, struct format)
_PCK_TYPES = {
    ParamType.INT8: (1, "<b"),
    ParamType.INT16: (2, "<h"),
    ParamType.INT32: (3, "<i"),
    ParamType.REAL32: (4, "<f"),
}
_PCK_HAS_DEFAULT = 0x10  # flag bit 0 of the high nibble of the type byte


class FtpOp(enum.IntEnum):
    NONE = 0
    TERMINATE_SESSION = 1
    RESET_SESSIONS = 2
    LIST_DIRECTORY = 3
    OPEN_FILE_RO = 4
    READ_FILE = 5
    CREATE_FILE = 6
    WRITE_FILE = 7
    REMOVE_FILE = 8
    CREATE_DIRECTORY = 9
    REMOVE_DIRECTORY = 10
    OPEN_FILE_WO = 11
    TRUNCATE_FILE = 12
    RENAME = 13
    CALC_FILE_CRC32 = 14
    BURST_READ_FILE = 15
    ACK = 128
    NAK = 129


class FtpError(enum.IntEnum):
    NONE = 0
    FAIL = 1
    FAIL_ERRNO = 2
    INVALID_DATA_SIZE = 3
    INVALID_SESSION = 4
    NO_SESSIONS_AVAILABLE = 5
    EOF = 6
    UNKNOWN_COMMAND = 7
    FILE_EXISTS = 8
    FILE_PROTECTED = 9
    FILE_NOT_FOUND = 10


_WRITES = {
    FtpOp.CREATE_FILE, FtpOp.WRITE_FILE, FtpOp.REMOVE_FILE, FtpOp.CREATE_DIRECTORY,
    FtpOp.REMOVE_DIRECTORY, FtpOp.OPEN_FILE_WO, FtpOp.TRUNCATE_FILE, FtpOp.RENAME,
}  # fmt: skip


def pack_params(store: ParamStore, with_defaults: bool = False) -> bytes:
    """``store`` in ArduPilot's packed parameter format: a header (magic, count, count: u16
    each), then per parameter a type byte (low nibble 1 int8 / 2 int16 / 3 int32 / 4 float;
    high nibble flags, 1: a default follows), a length byte (low nibble: characters shared
    with the previous name; high nibble: the rest's length - 1), the rest of the name, the
    value and, when flagged, the default. With defaults, the flag marks values that differ."""
    out = bytearray(
        struct.pack("<HHH", PCK_MAGIC_WITH_DEFAULTS if with_defaults else PCK_MAGIC,
                    len(PARAMS), len(PARAMS))
    )  # fmt: skip
    previous = b""
    for index, spec in enumerate(PARAMS):
        code, fmt = _PCK_TYPES[spec.param_type]
        name = spec.name.encode("ascii")
        common = 0
        while common < min(len(name) - 1, len(previous), 15) and name[common] == previous[common]:
            common += 1
        rest = name[common:]
        value, default = store.values[index], store.defaults[index]
        has_default = with_defaults and value != default
        type_byte = code | (_PCK_HAS_DEFAULT if has_default else 0)
        out += bytes((type_byte, common | (len(rest) - 1) << 4))
        out += rest + _packed(fmt, value)
        if has_default:
            out += _packed(fmt, default)
        previous = name
    return bytes(out)


def _packed(fmt: str, value: float) -> bytes:
    return struct.pack(fmt, value if fmt == "<f" else round(value))


@dataclass(frozen=True)
class _Request:
    seq: int
    session: int
    opcode: int
    size: int
    offset: int
    data: bytes

    @classmethod
    def parse(cls, payload: bytes) -> _Request:
        raw = payload.ljust(HEADER.size, b"\0")
        seq, session, opcode, size, _req, _burst, _pad, offset = HEADER.unpack_from(raw)
        return cls(seq, session, opcode, size, offset, bytes(raw[HEADER.size :][:size]))

    def path(self) -> str:
        return self.data.split(b"\0", 1)[0].decode("ascii", "replace")


@dataclass
class FtpServer:
    """One link's FTP server: open read-only sessions (session id -> file bytes) per client."""

    sessions: dict[tuple[int, int, int], bytes] = field(default_factory=dict)

    def handle(
        self, msg: pm.FileTransferProtocol, params: ParamStore, client: tuple[int, int]
    ) -> list[pm.FileTransferProtocol]:
        request = _Request.parse(msg.payload)
        replies = self._answer(request, params, client)
        return [pm.FileTransferProtocol(0, client[0], client[1], payload) for payload in replies]

    def _answer(
        self, request: _Request, params: ParamStore, client: tuple[int, int]
    ) -> list[bytes]:
        key = (*client, request.session)
        op = request.opcode
        if op in (FtpOp.NONE, FtpOp.TERMINATE_SESSION, FtpOp.RESET_SESSIONS):
            return [self._session_op(request, key)]
        if op == FtpOp.LIST_DIRECTORY:
            return [self._list(request, params)]
        if op == FtpOp.OPEN_FILE_RO:
            return [self._open(request, params, key)]
        if op in (FtpOp.READ_FILE, FtpOp.BURST_READ_FILE):
            return self._read(request, self.sessions.get(key))
        protected = op in _WRITES and request.path().startswith(PARAM_DIR)
        return [_nak(request, FtpError.FILE_PROTECTED if protected else FtpError.UNKNOWN_COMMAND)]

    def _session_op(self, request: _Request, key: tuple[int, int, int]) -> bytes:
        if request.opcode == FtpOp.TERMINATE_SESSION and self.sessions.pop(key, None) is None:
            return _nak(request, FtpError.INVALID_SESSION)
        if request.opcode == FtpOp.RESET_SESSIONS:
            for each in [k for k in self.sessions if k[:2] == key[:2]]:
                del self.sessions[each]
        return _ack(request, b"")

    @staticmethod
    def _read(request: _Request, content: bytes | None) -> list[bytes]:
        burst = request.opcode == FtpOp.BURST_READ_FILE
        if content is None:
            return [_nak(request, FtpError.INVALID_SESSION)]
        if request.offset >= len(content):
            return [_nak(request, FtpError.EOF, burst=burst)]
        if burst:
            return _burst(request, content)
        return [_ack(request, content[request.offset : request.offset + _chunk(request)])]

    def _list(self, request: _Request, params: ParamStore) -> bytes:
        path = request.path().rstrip("/") or "/"
        if path == "/":
            entries = [f"D{PARAM_DIR}"]
        elif path == PARAM_DIR:
            entries = [f"F{PARAM_FILE}\t{len(pack_params(params))}"]
        else:
            return _nak(request, FtpError.FILE_NOT_FOUND)
        if request.offset >= len(entries):
            return _nak(request, FtpError.EOF)
        data = b""
        for entry in entries[request.offset :]:
            encoded = entry.encode("ascii") + b"\0"
            if len(data) + len(encoded) > MAX_DATA:
                break
            data += encoded
        return _ack(request, data)

    def _open(self, request: _Request, params: ParamStore, key: tuple[int, int, int]) -> bytes:
        path, _, query = request.path().partition("?")
        if path.lstrip("/") != f"{PARAM_DIR}/{PARAM_FILE}":
            return _nak(request, FtpError.FILE_NOT_FOUND)
        if key not in self.sessions and len(self.sessions) >= MAX_SESSIONS:
            return _nak(request, FtpError.NO_SESSIONS_AVAILABLE)
        content = pack_params(params, with_defaults=WITH_DEFAULTS in query.split("&"))
        self.sessions[key] = content  # a snapshot: reads see one consistent table
        return _ack(request, struct.pack("<I", len(content)))


def _chunk(request: _Request) -> int:
    return request.size if 0 < request.size <= MAX_DATA else MAX_DATA


def _burst(request: _Request, content: bytes) -> list[bytes]:
    """Every chunk from ``offset`` to the end, the last marked burst complete (a client that
    asks on from a full-size last chunk gets NAK EOF)."""
    chunk = _chunk(request)
    offsets = range(request.offset, len(content), chunk)
    return [
        _reply(request.seq + k, request, FtpOp.ACK, content[offset : offset + chunk], offset,
               offset + chunk >= len(content))
        for k, offset in enumerate(offsets)
    ]  # fmt: skip


def _ack(request: _Request, data: bytes) -> bytes:
    return _reply(request.seq, request, FtpOp.ACK, data, request.offset, False)


def _nak(request: _Request, error: FtpError, burst: bool = False) -> bytes:
    return _reply(request.seq, request, FtpOp.NAK, bytes((error,)), request.offset, burst)


def _reply(
    after_seq: int, request: _Request, opcode: FtpOp, data: bytes, offset: int, complete: bool
) -> bytes:
    header = HEADER.pack(
        (after_seq + 1) & 0xFFFF, request.session, opcode, len(data), request.opcode,
        int(complete), 0, offset,
    )  # fmt: skip
    return header + data
