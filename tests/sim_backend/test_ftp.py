"""MAVLink FTP of the sim autopilot: the parameter file as ArduCopter offers it, over real
MAVLink bytes in memory (``SimPair``), decoded with MAVProxy's own param.pck parser; and
MAVProxy's ftp module against ``ridsafe sim`` over UDP."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest

from ridsafe.common import protocol_messages as pm
from ridsafe.sim_backend.ftp import HEADER, MAX_DATA, FtpError, FtpOp
from ridsafe.sim_backend.param_table import PARAMS
from tests.sim_backend.helpers import SimPair
from tests.sim_backend.test_mavproxy_client import MAVPROXY, MODULES, Console
from tests.sim_backend.udp_sim import sim_on_udp

param_ftp = pytest.importorskip("MAVProxy.modules.lib.param_ftp")

GCS_BASE, COMPANION_BASE = 26550, 27760


class Reply:
    def __init__(self, payload: bytes) -> None:
        fields = HEADER.unpack_from(payload)
        self.seq, self.session, self.opcode, self.size, self.req_opcode = fields[:5]
        self.burst_complete, _pad, self.offset = fields[5:]
        self.data = payload[HEADER.size :][: self.size]


def request(pair: SimPair, op: FtpOp, data: bytes = b"", offset: int = 0, size: int | None = None,
            seq: int = 7, session: int = 3) -> list[Reply]:  # fmt: skip
    """One FTP request; every FTP reply addressed to the station."""
    header = HEADER.pack(seq, session, op, len(data) if size is None else size, 0, 0, 0, offset)
    start = len(pair.received)
    pair.step([pm.FileTransferProtocol(0, 1, 1, header + data)])
    pair.run(0.1)
    replies = [r.message for r in pair.received[start:]]
    out = []
    for msg in replies:
        if isinstance(msg, pm.FileTransferProtocol):
            assert (msg.target_system, msg.target_component) == (255, 190)
            out.append(Reply(msg.payload))
    return out


def nak(reply: Reply) -> FtpError:
    assert reply.opcode == FtpOp.NAK and reply.size == 1
    return FtpError(reply.data[0])


@pytest.fixture
def pair() -> SimPair:
    p = SimPair()
    p.run(0.5)
    return p


def read_all(pair: SimPair, path: bytes) -> bytes:
    (opened,) = request(pair, FtpOp.OPEN_FILE_RO, path)
    assert (opened.opcode, opened.req_opcode, opened.seq, opened.session) == (
        FtpOp.ACK, FtpOp.OPEN_FILE_RO, 8, 3)  # fmt: skip
    (size,) = struct.unpack("<I", opened.data)
    burst = request(pair, FtpOp.BURST_READ_FILE, size=MAX_DATA)
    assert all(r.opcode == FtpOp.ACK and r.req_opcode == FtpOp.BURST_READ_FILE for r in burst)
    assert [r.burst_complete for r in burst] == [0] * (len(burst) - 1) + [1]
    content = b"".join(r.data for r in burst)
    assert len(content) == size and [r.offset for r in burst] == list(range(0, size, MAX_DATA))
    assert nak(request(pair, FtpOp.BURST_READ_FILE, offset=size, size=MAX_DATA)[0]) is FtpError.EOF
    (ended,) = request(pair, FtpOp.TERMINATE_SESSION)
    assert ended.opcode == FtpOp.ACK
    return content


def test_directories_list_the_parameter_file(pair: SimPair) -> None:
    (root,) = request(pair, FtpOp.LIST_DIRECTORY, b"/")
    assert root.opcode == FtpOp.ACK and root.data == b"D@PARAM\0"
    (params,) = request(pair, FtpOp.LIST_DIRECTORY, b"@PARAM")
    name, size = params.data.rstrip(b"\0").decode().split("\t")
    assert name == "Fparam.pck" and int(size) > 6 * len(PARAMS)
    assert nak(request(pair, FtpOp.LIST_DIRECTORY, b"@PARAM", offset=1)[0]) is FtpError.EOF
    assert nak(request(pair, FtpOp.LIST_DIRECTORY, b"/no/such")[0]) is FtpError.FILE_NOT_FOUND


def test_the_parameter_file_decodes_with_mavproxys_parser_to_the_table(pair: SimPair) -> None:
    values = pair.backend.autopilots[0].params.values
    decoded = param_ftp.ftp_param_decode(read_all(pair, b"@PARAM/param.pck"))
    assert [name.decode() for name, _, _ in decoded.params] == [spec.name for spec in PARAMS]
    assert [v for _, v, _ in decoded.params] == pytest.approx(values)
    assert decoded.defaults is None


def test_with_defaults_the_file_carries_the_defaults_of_changed_values(pair: SimPair) -> None:
    pair.step([pm.ParamSet(1, 1, "RTL_ALT", 2500.0, int(pm.ParamType.REAL32))])
    decoded = param_ftp.ftp_param_decode(read_all(pair, b"@PARAM/param.pck?withdefaults=1"))
    values = {name.decode(): v for name, v, _ in decoded.params}
    defaults = {name.decode(): v for name, v, _ in decoded.defaults}
    assert (values["RTL_ALT"], defaults["RTL_ALT"]) == (2500.0, 1500.0)
    assert values["WPNAV_SPEED"] == defaults["WPNAV_SPEED"] == 1000.0


def test_read_file_reads_a_chunk_at_an_offset(pair: SimPair) -> None:
    whole = read_all(pair, b"@PARAM/param.pck")
    request(pair, FtpOp.OPEN_FILE_RO, b"/@PARAM/param.pck")
    (chunk,) = request(pair, FtpOp.READ_FILE, offset=10, size=20)
    assert chunk.opcode == FtpOp.ACK and chunk.data == whole[10:30]
    assert nak(request(pair, FtpOp.READ_FILE, offset=len(whole), size=20)[0]) is FtpError.EOF


def test_errors_are_naked_as_ardupilot_does(pair: SimPair) -> None:
    assert nak(request(pair, FtpOp.OPEN_FILE_RO, b"@PARAM/nope")[0]) is FtpError.FILE_NOT_FOUND
    assert nak(request(pair, FtpOp.READ_FILE, size=10)[0]) is FtpError.INVALID_SESSION
    assert nak(request(pair, FtpOp.TERMINATE_SESSION)[0]) is FtpError.INVALID_SESSION
    assert nak(request(pair, FtpOp.CREATE_FILE, b"@PARAM/x")[0]) is FtpError.FILE_PROTECTED
    assert nak(request(pair, FtpOp.REMOVE_FILE, b"/log.bin")[0]) is FtpError.UNKNOWN_COMMAND
    assert nak(request(pair, FtpOp.CALC_FILE_CRC32, b"/x")[0]) is FtpError.UNKNOWN_COMMAND
    for session in range(4):
        (ok,) = request(pair, FtpOp.OPEN_FILE_RO, b"@PARAM/param.pck", session=session)
        assert ok.opcode == FtpOp.ACK
    full = request(pair, FtpOp.OPEN_FILE_RO, b"@PARAM/param.pck", session=9)
    assert nak(full[0]) is FtpError.NO_SESSIONS_AVAILABLE
    (reset,) = request(pair, FtpOp.RESET_SESSIONS)
    assert reset.opcode == FtpOp.ACK
    (again,) = request(pair, FtpOp.OPEN_FILE_RO, b"@PARAM/param.pck", session=9)
    assert again.opcode == FtpOp.ACK


@pytest.mark.udp
@pytest.mark.slow
@pytest.mark.skipif(MAVPROXY is None, reason="MAVProxy is a [test] extra")
def test_mavproxy_fetches_the_parameters_over_ftp(tmp_path: Path) -> None:
    with sim_on_udp(GCS_BASE, COMPANION_BASE, speed=2.0) as backend:
        console = Console(tmp_path, GCS_BASE, MODULES + ",ftp")
        try:
            console.wait_for(lambda: console.said("online system 1"), 20.0, "the vehicle")
            console.send("param fetch")
            console.wait_for(lambda: console.said(f"Received {len(PARAMS)} parameters (ftp)"),
                             30.0, "param fetch over FTP")  # fmt: skip
            console.send("ftp list @PARAM")
            console.wait_for(lambda: console.said("param.pck"), 20.0, "ftp list")
            console.send("ftp get @PARAM/param.pck got.pck")
            got = tmp_path / "got.pck"
            console.wait_for(lambda: console.said("Wrote") or console.said("got.pck"), 20.0,
                             "ftp get")  # fmt: skip
            console.wait_for(lambda: got.exists() and got.stat().st_size > 0, 10.0, "the file")
        finally:
            console.close()
        decoded = param_ftp.ftp_param_decode(got.read_bytes())
        values = backend.autopilots[0].params.values
        assert [v for _, v, _ in decoded.params] == pytest.approx(values)
