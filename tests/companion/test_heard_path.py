"""The heard-frame path end to end: sim radio -> RIDSAFE_RID_FRAME on the companion link ->
companion -> observation report. Each report carries the RSSI the radio drew for the very
reception its frame came in (to float32, the wire's type); nothing pairs anything.

Oracle: the radio's own list of receptions (``SimBackend.last_receptions``), each with its
sender, frame and RSSI, with shadowing on so that every reception's RSSI is different.
"""

from __future__ import annotations

from typing import cast

import numpy as np

from ridsafe.common import f3411, topics
from ridsafe.common.scenario import RadioConfig, Scenario
from tests.companion.test_companion_core import AIRCRAFT, ORIGIN, Flight


def _scenario() -> Scenario:
    radio = RadioConfig(shadowing_sigma_db=4.0)  # every reception's RSSI differs
    return Scenario(ORIGIN, AIRCRAFT[:3], None, radio, seed=11)


def test_each_observation_carries_the_rssi_of_its_own_reception() -> None:
    flight = Flight(_scenario())
    heard_by_1: list[tuple[str, int, float]] = []  # (sender serial, F3411 type, RSSI)
    serials = [a.serial for a in flight.scenario.aircraft]
    for _ in range(round(12.0 / 0.02)):
        flight.step()
        for rx in flight.sim.last_receptions:
            if rx.receiver == 0:
                kind = int(f3411.message_type(rx.transmission.payload))
                heard_by_1.append((serials[rx.transmission.sender], kind, rx.rssi_dbm))
    companion = flight.companions[1]
    reported = [
        item
        for _, record in flight.sinks[1].on(topics.OBSERVATIONS)
        for item in cast(list[dict[str, object]], record["items"])
    ]
    locations = [
        (serial, float(np.float32(dbm)))
        for serial, kind, dbm in heard_by_1
        if kind == f3411.MessageType.LOCATION
    ]
    assert len(reported) >= 10 and len({item["rssi_dbm"] for item in reported}) == len(reported)
    for item in reported:
        assert (item["uas_id"], item["rssi_dbm"]) in locations
    # one RIDSAFE_RID_FRAME per reception, every LOCATION reported or counted
    counters = companion.counters_snapshot()
    assert counters["receiver.frames"] in (len(heard_by_1), len(heard_by_1) - 1)
    assert counters["observations.frames"] == counters["receiver.frames"]
    assert counters["observations.frame_errors"] == 0
    heard = counters["observations.heard"]
    assert heard >= len(reported)
    batch = companion.observations.batcher.take_all()  # the batch not yet due
    waiting = 0 if batch is None else len(batch)
    assert heard == len(reported) + counters["observations.no_own_position"] + waiting
