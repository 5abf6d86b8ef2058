"""PlannerConfig: the paper's defaults, validation naming the field, YAML loading."""

from __future__ import annotations

import pytest

from ridsafe.common.config import from_mapping, parse_yaml, to_mapping
from ridsafe.common.errors import ConfigError, FieldValueError
from ridsafe.companion.actions import build_action_set
from ridsafe.companion.planner_config import ArrivalAction, PlannerConfig


def test_defaults_are_the_papers_reward_table_and_the_authors_action_set() -> None:
    cfg = PlannerConfig()
    assert (cfg.goal_reward, cfg.goal_decay) == (200.0, 0.999)
    assert (cfg.benign_reward_base, cfg.benign_reward_per_s, cfg.benign_decay) == (
        -500.0,
        -100.0,
        0.97,
    )
    assert (cfg.region_reward, cfg.region_decay) == (-1000.0, 0.97)
    assert cfg.n_headings == 16 and cfg.speeds_m_s == (8.0, 6.0, 4.0, 2.0)
    assert len(cfg.flight_path_angles_deg) == 13 and max(cfg.flight_path_angles_deg) == 20.0
    assert (cfg.horizon_s, cfg.n_samples, cfg.replan_period_s) == (10.0, 20, 0.5)
    assert cfg.arrival_radius_m == 10.0
    assert cfg.max_speed_m_s == 8.0 and cfg.max_tilt_deg == 30.0
    assert cfg.sample_times_s[0] == 0.5 and cfg.sample_times_s[-1] == 10.0


def test_n_actions_is_the_action_set_size() -> None:
    for cfg in (
        PlannerConfig(),
        PlannerConfig(n_headings=8, speeds_m_s=(8.0,), flight_path_angles_deg=(0.0,)),
    ):
        assert len(build_action_set(cfg, 1.0)) == cfg.n_actions


@pytest.mark.parametrize(
    ("field", "value", "says"),
    [
        ("goal_decay", 1.0, "decay must lie in (0, 1)"),
        ("benign_decay", 0.0, "decay must lie in (0, 1)"),
        ("region_reward", 1000.0, "hazard reward must be < 0"),
        ("benign_reward_per_s", 100.0, "longer conflicts cost more"),
        ("d_safe_m", -5.0, "must be finite and > 0"),
        ("benign_vertical_weight", 0.5, "must be >= 1"),
        ("benign_vertical_weight", float("nan"), "must be >= 1"),
        ("speeds_m_s", (9.0,), "max_speed_m_s"),
        ("flight_path_angles_deg", (), "must not be empty"),
        ("accel_m_s2", 6.0, "g tan(max_tilt_deg)"),
        ("velocity_lead_s", 20.0, "horizon_s"),
        ("min_altitude_m", 130.0, "max_altitude_m"),
        ("n_samples", 0, ">= 1"),
        ("approach_min_separation_m", 150.0, "d_safe_m=100.0"),
    ],
)
def test_validation_names_the_field(field: str, value: object, says: str) -> None:
    with pytest.raises(FieldValueError) as err:
        PlannerConfig(**{field: value})  # type: ignore[arg-type]
    assert err.value.field.startswith(field) and says in err.value.reason


def test_loads_from_a_yaml_planner_section() -> None:
    text = """
d_safe_m: 80
on_arrival: land
flight_path_angles_deg: [0, 5, -5]
"""
    cfg = from_mapping(PlannerConfig, parse_yaml(text, "planner.yaml"), "planner.yaml")
    assert cfg.d_safe_m == 80.0 and cfg.on_arrival is ArrivalAction.LAND
    assert cfg.flight_path_angles_deg == (0.0, 5.0, -5.0)
    assert from_mapping(PlannerConfig, to_mapping(cfg), "round trip") == cfg


def test_yaml_errors_name_file_and_key() -> None:
    with pytest.raises(
        ConfigError, match=r"planner.yaml: d_safe: unknown key.*did you mean d_safe_m"
    ):
        from_mapping(PlannerConfig, {"d_safe": 80}, "planner.yaml")
    with pytest.raises(ConfigError, match=r"planner.yaml: goal_decay: a decay must lie in"):
        from_mapping(PlannerConfig, {"goal_decay": 2}, "planner.yaml")
