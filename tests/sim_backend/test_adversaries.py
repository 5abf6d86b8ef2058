"""Spoofers and ghosts in the sim: every motion kind flies as configured, every claim says what
it should, silent windows are silent, random power changes per message, and the truth channel
records each adversary's claimed state.

Oracles: the missions' closed forms (orbit radius and speed, pursuit closing in), the claims'
definitions evaluated by hand at the logged times, the radio's RSSI residual against free space.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ridsafe.common import topics
from ridsafe.common.adversary import ClaimConfig
from ridsafe.common.config import load_config
from ridsafe.common.logsink import LogSink
from ridsafe.common.pathloss import received_power_dbm
from ridsafe.sim_backend.adversary_claim import Claim, TrackHistory
from ridsafe.sim_backend.adversary_motion import OrbitMission, PursueMission, WaypointPath
from ridsafe.sim_backend.world import SimBackend
from ridsafe.tools.run.scenario import ScenarioFile

EXAMPLE = Path(__file__).parents[1] / "common" / "adversaries_example.yaml"


class _Records(LogSink):
    def __init__(self) -> None:
        self.records: list[tuple[str, float, dict[str, object]]] = []

    def log(self, topic: str, t_s: float, record: Mapping[str, Any]) -> None:
        self.records.append((topic, t_s, dict(record)))


@pytest.fixture(scope="module")
def flown() -> tuple[SimBackend, _Records, list[np.ndarray]]:
    scenario = load_config(EXAMPLE, ScenarioFile).scenario
    sink = _Records()
    backend = SimBackend(scenario, sink=sink)
    positions = []
    for k in range(1, 401):  # 20 s
        backend.handle(k * 0.05, [])
        positions.append(backend.fleet.state[:, 0:3].copy())
    return backend, sink, positions


def test_the_orbit_stays_on_its_circle_at_its_speed() -> None:
    orbit = OrbitMission((10.0, 20.0, 60.0), 50.0, 5.0, clockwise=True)
    for t in (0.0, 3.0, 17.5):
        p, v = orbit.target(t)
        assert math.hypot(p[0] - 10.0, p[1] - 20.0) == pytest.approx(50.0)
        assert float(np.linalg.norm(v)) == pytest.approx(5.0)
    p1, _ = orbit.target(1.0)
    assert p1[1] < 20.0  # clockwise from the east point: heads south


def test_a_looping_waypoint_path_comes_back_to_its_first_point() -> None:
    path = WaypointPath([(0.0, 0.0, 10.0), (30.0, 0.0, 10.0), (30.0, 40.0, 10.0)], 10.0, loop=True)
    assert path.length_m == pytest.approx(30.0 + 40.0 + 50.0)
    p, _ = path.target(12.0)  # 120 m: the loop is closed
    np.testing.assert_allclose(p, (0.0, 0.0, 10.0), atol=1e-9)
    p, v = path.target(5.0)  # 50 m: 20 m up the second leg
    np.testing.assert_allclose(p, (30.0, 20.0, 10.0), atol=1e-9)
    np.testing.assert_allclose(v, (0.0, 10.0, 0.0), atol=1e-9)


def test_the_pursuer_aims_at_its_target_and_stops_at_the_standoff() -> None:
    target = np.array([100.0, 0.0, 60.0])
    own = np.array([0.0, 0.0, 60.0])
    chase = PursueMission(lambda: own, lambda: target, 6.0, standoff_m=20.0)
    p, v = chase.target(0.0)
    np.testing.assert_allclose(v, (6.0, 0.0, 0.0))
    np.testing.assert_allclose(p, own)  # the reference starts on the pursuer
    own = np.array([2.5, 0.0, 60.0])
    p, v = chase.target(0.5)  # ... and moves at the pursuit speed
    np.testing.assert_allclose(p, (3.0, 0.0, 60.0))
    own = np.array([85.0, 0.0, 60.0])  # the reference is pulled back to one second of flight
    p, v = chase.target(20.0)  # (79 m), then closes to the standoff (80 m)
    np.testing.assert_allclose(p, (80.0, 0.0, 60.0))
    p, v = chase.target(20.5)  # at the standoff: it holds
    np.testing.assert_allclose(v, 0.0)
    np.testing.assert_allclose(p, (80.0, 0.0, 60.0))


def test_the_pursuer_flies_at_its_pursuit_speed_not_faster(
    flown: tuple[SimBackend, _Records, list[np.ndarray]],
) -> None:
    """The example's pursuer (6 m/s, its target 500 m away) in the sim's own dynamics: a
    position target always one second ahead made it fly at 8 m/s, as fast as its victim."""
    _, _, positions = flown
    track = np.array([p[4] for p in positions])  # 0.05 s steps; column 4 = the pursuer
    speed_m_s = np.linalg.norm(track[100:, :2] - track[99:-1, :2], axis=1) / 0.05
    assert float(np.max(speed_m_s)) <= 6.3
    assert float(np.mean(speed_m_s)) == pytest.approx(6.0, abs=0.2)


def test_drift_is_honest_until_its_start_then_grows_at_its_rate_to_its_cap() -> None:
    claim = Claim(
        ClaimConfig("drift", rate_enu_m_s=(3.0, 4.0, 0.0), start_s=10.0, max_offset_m=25.0)
    )
    p, v = np.array([1.0, 2.0, 60.0]), np.array([1.0, 0.0, 0.0])
    np.testing.assert_allclose(claim.state(5.0, p, v)[0], p)
    claimed, claimed_v = claim.state(12.0, p, v)
    np.testing.assert_allclose(claimed - p, (6.0, 8.0, 0.0))
    np.testing.assert_allclose(claimed_v, (4.0, 4.0, 0.0))  # the rate is part of the lie
    claimed, claimed_v = claim.state(100.0, p, v)
    assert float(np.linalg.norm(claimed - p)) == pytest.approx(25.0)
    np.testing.assert_allclose(claimed_v, v)


def test_a_bystander_claims_where_it_is() -> None:
    claim = Claim(ClaimConfig("truth"))
    p, v = np.array([1.0, 2.0, 60.0]), np.array([1.0, -3.0, 0.5])
    claimed, claimed_v = claim.state(7.0, p, v)
    np.testing.assert_array_equal(claimed, p)
    np.testing.assert_array_equal(claimed_v, v)
    claimed[0] = 99.0  # the claim is its own copy: the truth is not moved by a consumer
    assert p[0] == 1.0


def test_mimic_claims_where_its_target_was_delay_seconds_ago() -> None:
    history = TrackHistory()
    for k in range(20):
        history.record(float(k), np.array([float(k), 0.0, 50.0]), np.array([1.0, 0.0, 0.0]))
    claim = Claim(ClaimConfig("mimic", target_serial="RSAF800000001", delay_s=5.0), history)
    claimed, _ = claim.state(12.0, np.zeros(3), np.zeros(3))
    np.testing.assert_allclose(claimed, (7.0, 0.0, 50.0))


def test_every_adversary_is_on_the_truth_channel_with_its_claim(
    flown: tuple[SimBackend, _Records, list[np.ndarray]],
) -> None:
    _, sink, _ = flown
    truths = [(t, r) for topic, t, r in sink.records if topic == topics.TRUTH]
    assert truths
    _, last = truths[-1]
    adversaries = last["adversaries"]
    assert isinstance(adversaries, list)
    assert [a["serial"] for a in adversaries] == [
        "RSAF800000666", "RSAF800000667", "RSAF800000668", "RSAF800000669", "RSAF800000777"
    ]  # fmt: skip
    p = np.asarray(last["p_enu_m"])
    by_serial = {a["serial"]: a for a in adversaries}
    np.testing.assert_allclose(  # offset
        by_serial["RSAF800000666"]["claimed_p_enu_m"], p[3] + (50.0, 50.0, 0.0), atol=1e-3
    )
    np.testing.assert_allclose(by_serial["RSAF800000669"]["claimed_p_enu_m"], (100.0, 100.0, 60.0))
    assert by_serial["RSAF800000777"]["role"] == "ghost"
    # the ghost's transmitter holds its place; the orbiting spoofer is on its circle
    np.testing.assert_allclose(p[7], (300.0, -200.0, 2.0), atol=1.0)
    assert math.hypot(p[5][0], p[5][1] - 400.0) == pytest.approx(60.0, abs=8.0)


def test_a_silent_spoofer_sends_nothing_in_its_window_and_sends_again_after(
    flown: tuple[SimBackend, _Records, list[np.ndarray]],
) -> None:
    _, sink, _ = flown
    sent = [
        t
        for topic, t, r in sink.records
        if topic == topics.RADIO_TX
        for item in r["items"]  # type: ignore[attr-defined]
        if item["sender"] == 4
    ]
    assert any(t < 10.0 for t in sent) and any(t >= 15.0 for t in sent)
    assert not [t for t in sent if 10.0 <= t < 15.0]


def test_a_random_power_transmitter_changes_power_every_message(
    flown: tuple[SimBackend, _Records, list[np.ndarray]],
) -> None:
    _, sink, positions = flown
    residuals = []
    for topic, t, record in sink.records:
        if topic != topics.RADIO_RX:
            continue
        k = round(t / 0.05) - 1
        for item in record["items"]:  # type: ignore[attr-defined]
            if item["sender"] == 5 and item["receiver"] == 1:
                d = float(np.linalg.norm(positions[k][4] - positions[k][0]))
                residuals.append(item["rssi_dbm"] - float(received_power_dbm(20.0, d)))
    assert len(residuals) > 10
    # shadowing alone is 1 dB; a 6 dB power spread shows
    assert 3.5 < float(np.std(residuals)) < 9.0
