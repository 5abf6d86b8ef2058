"""Regression tests of issue 14 on the companion: one forged datagram from the autopilot's
ids must neither crash the companion nor end its mission, nor stamp its log with absurd times."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from ridsafe.common import codec, topics
from ridsafe.common import messages as m
from ridsafe.common.codec.inbound import MAX_BOOT_TIME_S
from ridsafe.common.dialect import ridsafe_v20 as mav
from ridsafe.common.shell import Endpoint
from ridsafe.companion.companion import AUTOPILOT
from ridsafe.companion.mission import Phase
from ridsafe.companion.stale_regions import held_regions
from tests.companion.test_companion_core import HOVERING, Flight, _region, make_scenario

AUTOPILOT_IDS = (1, 1)  # system 1 (the vehicle), component 1 (the autopilot)


def _raw_system_time(time_unix_usec: int, time_boot_ms: int) -> bytes:
    """A SYSTEM_TIME with a valid CRC from the autopilot's ids, built field by field as an
    attacker would (the domain encoder refuses these values)."""
    sender = mav.MAVLink(None, srcSystem=AUTOPILOT_IDS[0], srcComponent=AUTOPILOT_IDS[1])
    msg = mav.MAVLink_system_time_message(time_unix_usec, time_boot_ms)
    return bytes(msg.pack(sender))


def _forge(flight: Flight, data: bytes) -> None:
    flight.to_companion[1].append((AUTOPILOT, data))


def _records_times(flight: Flight) -> list[float]:
    return [t for _, t, _ in flight.sinks[1].records]


def test_system_time_of_2_pow_64_is_rejected_counted_and_the_companion_keeps_flying() -> None:
    flight = Flight(make_scenario(1))
    flight.run_until(lambda: flight.companions[1].phase is Phase.CRUISE, 60.0)
    for _ in range(80):  # the 80 datagrams, one per step
        _forge(flight, _raw_system_time(2**64 - 1, 1000))
        flight.step()
    flight.run(4.0)
    companion = flight.companions[1]
    counters = companion.counters_snapshot()
    assert counters["companion.invalid.SYSTEM_TIME.time_unix_s"] == 80
    assert companion.phase in (Phase.CRUISE, Phase.ARRIVED, Phase.HOVER)
    assert companion.shell.counters.handler_errors == 0


def test_a_boot_time_far_ahead_is_dropped_and_never_stamps_a_log_record() -> None:
    flight = Flight(make_scenario(1))
    flight.run(20.0)
    for _ in range(40):
        _forge(flight, _raw_system_time(1_700_000_000_000_000, 2**32 - 1))
        flight.step()
    flight.run(2.0)
    companion = flight.companions[1]
    assert companion.autopilot.counters.clock_jumps == 40
    assert abs(companion.sim_time(flight.t_s) - flight.t_s) < 1.0
    assert max(_records_times(flight)) < flight.t_s + 1.0 < MAX_BOOT_TIME_S


def test_a_forged_disarmed_heartbeat_in_flight_does_not_fail_the_mission() -> None:
    flight = Flight(make_scenario(1))
    flight.run_until(lambda: flight.companions[1].phase is Phase.CRUISE, 60.0)
    forger = codec.MavlinkLink(*AUTOPILOT_IDS)
    disarmed = m.Heartbeat(
        int(m.MavType.OCTOROTOR),
        int(m.MavAutopilot.ARDUPILOTMEGA),
        int(m.MavModeFlag.CUSTOM_MODE_ENABLED),
        int(m.CopterMode.GUIDED),
        int(m.MavState.STANDBY),
    )
    for _ in range(20):
        _forge(flight, forger.pack(disarmed))
        flight.step()
    flight.run(5.0)
    companion = flight.companions[1]
    assert companion.autopilot.counters.implausible_disarm == 20
    assert companion.phase is not Phase.FAILED
    assert companion.phase in (Phase.CRUISE, Phase.ARRIVED, Phase.HOVER)


def test_an_error_while_handling_one_message_is_counted_and_the_next_is_handled() -> None:
    flight = Flight(make_scenario(1))
    companion = flight.companions[1]
    calls: list[m.Message] = []

    def fragile(endpoint: Endpoint, received: codec.Received) -> None:
        calls.append(received.message)
        if len(calls) == 1:
            raise RuntimeError("a bug in the core")

    sender = codec.MavlinkLink(*AUTOPILOT_IDS)
    heartbeat = m.Heartbeat(2, 3, 0, 0, 3)
    data = sender.pack(heartbeat) + sender.pack(heartbeat)
    companion.shell.dispatch([(AUTOPILOT, data)], fragile)
    assert len(calls) == 2
    assert companion.counters_snapshot()["companion.handler_errors"] == 1


def test_a_message_that_does_not_fit_its_fields_is_counted_not_raised() -> None:
    flight = Flight(make_scenario(1))
    companion = flight.companions[1]
    companion.shell.send(AUTOPILOT, m.SystemTime(math.inf, 0.0))
    assert companion.counters_snapshot()["companion.unencodable_out"] == 1
    assert companion.shell.flush() == []


def test_counters_record_carries_the_edge_rejections() -> None:
    flight = Flight(make_scenario(1))
    flight.run(1.0)
    _forge(flight, _raw_system_time(2**64 - 1, 1000))
    flight.run(1.0)
    flight.companions[1].finish(flight.t_s)
    records = [r for _, r in flight.sinks[1].on(topics.APP_COUNTERS)]
    assert records[-1]["counters"]["companion.invalid.SYSTEM_TIME.time_unix_s"] == 1


# --- a lost GCS: the last region is held, inflated (stale_regions) -----------------------------


def _held_flight(hold_s: float) -> Flight:
    config = replace(HOVERING, stale_region_hold_s=hold_s, stale_region_growth_m2_s=25.0)
    flight = Flight(make_scenario(1), config=config)
    flight.run_until(lambda: flight.companions[1].phase is Phase.CRUISE, max_s=20.0)
    return flight


def test_a_region_the_gcs_stops_refreshing_is_held_grown_by_the_documented_rule() -> None:
    flight = _held_flight(hold_s=30.0)
    t0 = flight.companions[1].sim_time(flight.t_s)
    sent = _region("RSAF800000666", (50.0, 40.0, 60.0), t0)  # valid for 2 s, then silence
    flight.send_from_gcs(1, [sent])
    flight.run(6.0)
    last = flight.planners[1].inputs[-1]
    (region,) = last.regions
    dt_s = last.t_s - t0
    assert dt_s > 5.0
    grow = 25.0 * dt_s
    expected_cov = ((100.0 + grow, 5.0, 0.0), (5.0, 80.0 + grow, 0.0), (0.0, 0.0, 50.0 + grow))
    np.testing.assert_allclose(region.cov_ned_m2, expected_cov, rtol=1e-12)
    home = flight.sim.homes[0]
    center0 = home.enu_to_local_ned(np.array([50.0, 40.0, 60.0]))
    np.testing.assert_allclose(
        region.center_ned_m, center0 + np.array(sent.v_ned_m_s) * dt_s, atol=0.01
    )
    assert region.chi2_threshold == pytest.approx(sent.chi2_threshold, rel=1e-6)  # float32
    companion = flight.companions[1]
    store = companion.regions
    now_s = sent.valid_until_s + 29.0
    assert held_regions(store.expired_last, now_s, 30.0, 25.0, companion.own.to_local)
    now_s = sent.valid_until_s + 31.0  # past the hold: gone
    assert held_regions(store.expired_last, now_s, 30.0, 25.0, companion.own.to_local) == ()
    assert store.expired_last == {}


def test_a_deleted_region_is_not_held_and_a_fresh_one_replaces_the_held_one() -> None:
    flight = _held_flight(hold_s=30.0)
    t0 = flight.companions[1].sim_time(flight.t_s)
    flight.send_from_gcs(1, [_region("RSAF800000666", (50.0, 40.0, 60.0), t0)])
    flight.run(4.0)
    t1 = flight.companions[1].sim_time(flight.t_s)
    fresh = _region("RSAF800000666", (80.0, 40.0, 60.0), t1)
    flight.send_from_gcs(1, [fresh])
    flight.run(0.6)
    (region,) = flight.planners[1].inputs[-1].regions
    assert region.cov_ned_m2[0][0] == 100.0  # the fresh one, not grown
    t2 = flight.companions[1].sim_time(flight.t_s)
    deleted = replace(fresh, t_s=t2, valid_until_s=t2, flags=int(m.RegionFlags.DELETED))
    flight.send_from_gcs(1, [deleted])
    flight.run(4.0)
    assert flight.planners[1].inputs[-1].regions == ()


def test_by_default_an_expired_region_is_dropped_as_before() -> None:
    flight = _held_flight(hold_s=0.0)
    t0 = flight.companions[1].sim_time(flight.t_s)
    flight.send_from_gcs(1, [_region("RSAF800000666", (50.0, 40.0, 60.0), t0)])
    flight.run(3.0)
    assert flight.planners[1].inputs[-1].regions == ()
