"""The backend core: routing, hostile input, determinism, the spoofer's flight."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ridsafe.common import codec, topics
from ridsafe.common import messages as m
from ridsafe.common.dialect import ridsafe_v20 as mav
from ridsafe.common.errors import ClockError
from ridsafe.common.logsink import MemorySink
from ridsafe.common.shell import MAX_DATAGRAM_BYTES
from ridsafe.sim_backend.config import SimConfig
from ridsafe.sim_backend.world import SimBackend
from tests.sim_backend.helpers import SimPair, scenario


def _telemetry_count(received: list[codec.Received]) -> int:
    return sum(isinstance(r.message, m.GlobalPositionInt) for r in received)


def test_garbage_truncated_and_unknown_frames_are_counted_and_the_sim_keeps_running() -> None:
    pair = SimPair()
    pair.run(1.0)
    good = pair.station.pack(m.CommandLong(1, 1, m.MavCmd.DO_SET_MODE, 0, (1, 4, 0, 0, 0, 0, 0)))
    unknown = bytes([0xFD, 3, 0, 0, 0, 9, 1, 0xFF, 0xFF, 0x00, 1, 2, 3, 0, 0])
    got = pair.step(raw=b"\x00garbage\xff" + unknown + good[:-3])
    got += pair.step(raw=good)
    counters = pair.backend.link_counters()["v1/gcs"]
    assert counters.bad_data + counters.unknown_id >= 2
    assert any(isinstance(r.message, m.CommandAck) for r in got)
    assert _telemetry_count(pair.run(1.0)) >= 9  # still streaming


def test_nan_and_out_of_range_fields_are_rejected_with_a_reason() -> None:
    pair = SimPair()
    raw = mav.MAVLink_home_position_message(910_000_000, 0, 0, 0, 0, 0, [1, 0, 0, 0], 0, 0, 0, 0)
    sender = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    pair.step(raw=bytes(raw.pack(sender)))
    counters = pair.backend.link_counters()["v1/gcs"]
    assert counters.invalid_value == 1 and "latitude 91.0" in counters.last_error


def test_command_for_a_vehicle_that_does_not_exist_is_dropped_and_counted() -> None:
    pair = SimPair()
    got = pair.step([m.CommandLong(9, 1, m.MavCmd.COMPONENT_ARM_DISARM, 0, (1, 0, 0, 0, 0, 0, 0))])
    assert not any(isinstance(r.message, m.CommandAck) for r in got)
    assert pair.backend.counters.wrong_vehicle == 1
    assert not pair.backend.fleet.armed.any()


def test_datagrams_for_unknown_endpoints_are_counted() -> None:
    backend = SimBackend(scenario(), SimConfig())
    backend.handle(0.02, [("v42/companion", b"\xfd\x00")])
    assert backend.shell.counters.unknown_endpoint == 1


def test_time_must_not_run_backwards() -> None:
    backend = SimBackend(scenario(), SimConfig())
    backend.handle(1.0, [])
    with pytest.raises(ClockError):
        backend.handle(0.5, [])
    with pytest.raises(ClockError):
        backend.handle(math.nan, [])


def test_datagrams_respect_the_size_cap() -> None:
    backend = SimBackend(scenario(4, spoofer=True), SimConfig())
    sizes = [len(d) for t in range(1, 200) for _, d in backend.handle(t * 0.02, [])]
    assert sizes and max(sizes) <= MAX_DATAGRAM_BYTES


def test_same_seed_same_inputs_give_identical_bytes() -> None:
    def run() -> list[tuple[str, bytes]]:
        backend = SimBackend(scenario(3, spoofer=True), SimConfig())
        out = []
        for k in range(1, 300):
            out.extend(backend.handle(k * 0.02, []))
        return out

    assert run() == run()


def test_spoofer_flies_its_line_at_constant_speed_and_claims_an_offset() -> None:
    sc = scenario(1, spoofer=True)
    backend = SimBackend(sc, SimConfig())
    assert sc.spoofer is not None
    for k in range(1, 501):
        backend.handle(k * 0.02, [])
    truth = backend.truth()
    p = truth.p_enu_m[-1]
    expected = np.array(sc.spoofer.start_enu_m) + np.array([sc.spoofer.speed_m_s * 10.0, 0, 0])
    assert np.linalg.norm(p - expected) < 1.0
    assert np.linalg.norm(truth.v_enu_m_s[-1] - [sc.spoofer.speed_m_s, 0, 0]) < 0.05
    assert truth.spoofer_claimed_p_enu_m is not None
    assert np.allclose(truth.spoofer_claimed_p_enu_m - p, sc.spoofer.offset_enu_m)
    assert truth.modes[-1] == m.CopterMode.AUTO and bool(truth.armed[-1])


def test_truth_and_radio_are_logged_per_the_topics_contract() -> None:
    sink = MemorySink()
    backend = SimBackend(scenario(2, spoofer=True), SimConfig(), sink=sink)
    for k in range(1, 251):  # 5 s
        backend.handle(k * 0.02, [])
    truth = sink.on(topics.TRUTH)
    assert 50 <= len(truth) <= 51
    required = set(topics.TOPICS[topics.TRUTH][1])
    assert all(required <= set(record) for _, record in truth)
    _, last = truth[-1]
    assert last["spoofer_sysid"] == 3 and len(last["p_enu_m"]) == 3
    received = [item for _, r in sink.on(topics.RADIO_RX) for item in r["items"]]
    assert {item["receiver"] for item in received} == {1, 2}
    assert all(item["sender"] == 3 for item in received)  # only the spoofer talks yet
    sent = [item for _, r in sink.on(topics.RADIO_TX) for item in r["items"]]
    assert len(sent) >= 5 + 1  # LOCATION at 1 Hz, the static messages in one pack
