"""The adversary configs: the issue's YAML loads as written, the shorthand means a line and an
offset, and every wrong value names its key path."""

from __future__ import annotations

from pathlib import Path

import pytest

from ridsafe.common.adversary import ClaimConfig, MotionConfig, SpooferConfig
from ridsafe.common.config import from_mapping, load_config, to_mapping
from ridsafe.common.errors import ConfigError, FieldValueError
from ridsafe.sim_backend.spoofer import StraightLineMission
from ridsafe.tools.run.scenario import ScenarioFile

EXAMPLE = Path(__file__).with_name("adversaries_example.yaml")


def test_the_issue_example_loads_with_every_kind() -> None:
    scenario = load_config(EXAMPLE, ScenarioFile).scenario
    kinds = [(s.resolved_motion.kind, s.resolved_claim.kind) for s in scenario.all_spoofers]
    assert kinds == [
        ("line", "offset"),
        ("pursue", "drift"),
        ("orbit", "mimic"),
        ("waypoints", "fixed"),
    ]
    assert (
        scenario.spoofers[1].tx_power is not None and scenario.spoofers[1].tx_power.kind == "random"
    )
    assert scenario.spoofers[0].silent_intervals_s == ((10.0, 15.0),)
    assert scenario.ghosts[0].transmitter_enu_m == (300.0, -200.0, 2.0)
    # sysids: 3 benign, 4 spoofers, then the ghost
    assert scenario.vehicle_count == 8
    assert scenario.serial_of(4) == "RSAF800000666" and scenario.serial_of(8) == "RSAF800000777"
    assert scenario.tx_power_dbm_of(5) == 20.0  # the random power's mean


def test_a_scenario_file_round_trips_through_plain_data() -> None:
    loaded = load_config(EXAMPLE, ScenarioFile)
    assert from_mapping(ScenarioFile, to_mapping(loaded), "round trip") == loaded


def test_the_single_spoofer_shorthand_is_a_line_with_an_offset() -> None:
    spoofer = SpooferConfig(
        "RSAF800000666", (0.0, 0.0, 60.0), (100.0, 0.0, 60.0), 6.0, (5.0, 0.0, 0.0)
    )
    assert spoofer.resolved_motion == MotionConfig(
        "line", 6.0, start_enu_m=(0.0, 0.0, 60.0), goal_enu_m=(100.0, 0.0, 60.0)
    )
    assert spoofer.resolved_claim == ClaimConfig("offset", offset_enu_m=(5.0, 0.0, 0.0))


def test_a_spoofer_that_stands_still_is_a_line_from_its_start_to_itself() -> None:
    """Speed 0 is refused with the way to say it; start == goal holds the start."""
    with pytest.raises(FieldValueError, match="hovers: goal_enu_m = start_enu_m"):
        SpooferConfig("RSAF800000666", (0.0, 0.0, 60.0), (100.0, 0.0, 60.0), 0.0)
    hover = SpooferConfig("RSAF800000666", (10.0, 20.0, 60.0), (10.0, 20.0, 60.0), 7.0)
    motion = hover.resolved_motion
    assert motion.start_enu_m is not None and motion.goal_enu_m is not None
    mission = StraightLineMission(motion.start_enu_m, motion.goal_enu_m, motion.speed_m_s)
    for t_s in (0.0, 5.0, 100.0):
        p, v = mission.target(t_s)
        assert p.tolist() == [10.0, 20.0, 60.0] and v.tolist() == [0.0, 0.0, 0.0]


def _with(text: str) -> str:
    return EXAMPLE.read_text().replace(
        "      claim: {kind: fixed, at_enu_m: [100.0, 100.0, 60.0]}", text
    )


@pytest.mark.parametrize(
    ("replacement", "path", "words"),
    [
        ("      claim: {kind: fixed}", "scenario.spoofers[3].claim.at_enu_m", "required"),
        (
            "      claim: {kind: fixed, at_enu_m: [0.0, 0.0, 60.0], delay_s: 3.0}",
            "scenario.spoofers[3].claim.delay_s",
            "not a key of kind 'fixed'",
        ),
        ("      claim: {kind: lie}", "scenario.spoofers[3].claim.kind", "lie"),
        (
            "      claim: {kind: mimic, target_serial: RSAF800000999}",
            "scenario.spoofers[3].claim.target_serial",
            "not a benign aircraft",
        ),
        (
            "      claim: {kind: fixed, at_enu_m: [100.0, 100.0, 60.0]}\n"
            "      tx_power: {kind: random, mean_dbm: 20.0}",
            "scenario.spoofers[3].tx_power.sigma_db",
            "required",
        ),
        (
            "      claim: {kind: fixed, at_enu_m: [100.0, 100.0, 60.0]}\n"
            "      silent_intervals_s: [[5.0, 2.0]]",
            "scenario.spoofers[3].silent_intervals_s[0]",
            "start < end",
        ),
    ],
)
def test_a_wrong_adversary_value_names_its_key_path(
    tmp_path: Path, replacement: str, path: str, words: str
) -> None:
    broken = tmp_path / "broken.yaml"
    broken.write_text(_with(replacement))
    with pytest.raises(ConfigError) as info:
        load_config(broken, ScenarioFile)
    assert path in str(info.value) and words in str(info.value)


def test_spoofer_and_spoofers_together_are_refused(tmp_path: Path) -> None:
    text = EXAMPLE.read_text().replace(
        "  spoofers:\n",
        "  spoofer: {serial: RSAF800000665, start_enu_m: [0.0, 0.0, 60.0],"
        " goal_enu_m: [1.0, 0.0, 60.0]}\n  spoofers:\n",
    )
    broken = tmp_path / "both.yaml"
    broken.write_text(text)
    with pytest.raises(ConfigError, match="not both"):
        load_config(broken, ScenarioFile)


def test_a_ghost_claims_a_path_or_a_place_only(tmp_path: Path) -> None:
    text = EXAMPLE.read_text().replace(
        "      claim: {kind: waypoints, waypoints_enu_m: [[-200.0, -200.0, 60.0],"
        " [200.0, 200.0, 60.0]], speed_m_s: 7.0}",
        "      claim: {kind: offset, offset_enu_m: [1.0, 0.0, 0.0]}",
    )
    broken = tmp_path / "ghost.yaml"
    broken.write_text(text)
    with pytest.raises(ConfigError, match=r"scenario.ghosts\[0\].claim.kind"):
        load_config(broken, ScenarioFile)
