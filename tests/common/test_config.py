"""Tests for ridsafe.common.config: YAML -> frozen dataclasses, errors naming file and key path."""

from __future__ import annotations

import enum
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import pytest

from ridsafe.common.config import (
    from_mapping,
    load_config,
    parse_override,
    to_mapping,
    with_overrides,
)
from ridsafe.common.errors import ConfigError, FieldValueError


class Mode(enum.Enum):
    CV = "cv"
    CA = "ca"


class Level(enum.Enum):
    LOW = 1
    HIGH = 2


@dataclass(frozen=True)
class ImmConfig:
    dt_s: float = 0.25
    mu0: tuple[float, float] = (0.45, 0.55)
    transition: tuple[tuple[float, float], ...] = ((0.98, 0.02), (0.16, 0.84))
    first_mode: Mode = Mode.CV

    def __post_init__(self) -> None:
        for i, row in enumerate(self.transition):
            total = sum(row)
            if abs(total - 1.0) > 1e-9:
                raise FieldValueError(f"transition[{i}]", f"row sums to {total:.2f}, must be 1")


@dataclass(frozen=True)
class GcsConfig:
    imm: ImmConfig = ImmConfig()
    update_period_s: float = 0.25
    method: Literal["trf", "lm"] = "trf"


@dataclass(frozen=True)
class RadioConfig:
    gain_db: float
    level: Level = Level.LOW


@dataclass(frozen=True)
class SimConfig:
    physics_hz: int
    controller_hz: int = 100
    speed: float = 1.0
    lockstep: bool = True
    offset_enu_m: tuple[float, float, float] = (50.0, 50.0, 0.0)
    key_file: Path | None = None
    name: str = "default"

    def __post_init__(self) -> None:
        if self.physics_hz % self.controller_hz:
            raise ValueError(
                f"physics_hz {self.physics_hz} is not a multiple of "
                f"controller_hz {self.controller_hz}"
            )


@dataclass(frozen=True)
class Scenario:
    sim: SimConfig
    gcs: GcsConfig = GcsConfig()
    radios: dict[str, RadioConfig] = field(default_factory=dict)
    seed: int | None = None


@dataclass(frozen=True)
class Unsupported:
    values: list[int]


GOOD_YAML = """\
sim:
  physics_hz: 400
  speed: 5          # an int where a float is expected is fine
  offset_enu_m: [140, 140.5, -50]
  key_file: keys/gcs.key
gcs:
  imm:
    dt_s: 1e-1      # YAML 1.1 would read this as a string
    transition: [[0.9, 0.1], [0.2, 0.8], [0.5, 0.5]]
    first_mode: CA  # by name
  method: lm
radios:
  rx1: {gain_db: 2.15, level: 2}   # enum by value
  rx2: {gain_db: 0}
seed: 7
"""


def write(tmp_path: Path, text: str, name: str = "scenario.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def load_error(tmp_path: Path, text: str) -> str:
    path = write(tmp_path, text)
    with pytest.raises(ConfigError) as info:
        load_config(path, Scenario)
    return str(info.value)


def test_nested_document_loads_with_types_from_hints(tmp_path: Path) -> None:
    cfg = load_config(write(tmp_path, GOOD_YAML), Scenario)
    assert cfg.sim == SimConfig(
        physics_hz=400, speed=5.0, offset_enu_m=(140.0, 140.5, -50.0), key_file=Path("keys/gcs.key")
    )
    assert type(cfg.sim.speed) is float
    assert cfg.gcs.imm.dt_s == pytest.approx(0.1)
    assert cfg.gcs.imm.transition == ((0.9, 0.1), (0.2, 0.8), (0.5, 0.5))
    assert cfg.gcs.imm.first_mode is Mode.CA
    assert cfg.gcs.imm.mu0 == (0.45, 0.55)  # default kept
    assert cfg.gcs.method == "lm"
    assert cfg.radios == {
        "rx1": RadioConfig(gain_db=2.15, level=Level.HIGH),
        "rx2": RadioConfig(gain_db=0.0),
    }
    assert cfg.seed == 7


def test_unknown_key_at_depth_two_names_the_full_path(tmp_path: Path) -> None:
    path = write(tmp_path, "sim: {physics_hz: 400}\ngcs:\n  imm:\n    transtion: [[1, 0]]\n")
    with pytest.raises(ConfigError) as info:
        load_config(path, Scenario)
    assert str(info.value) == (
        f"{path}: gcs.imm.transtion: unknown key "
        "(known: dt_s, mu0, transition, first_mode); did you mean transition?"
    )
    assert info.value.key_path == "gcs.imm.transtion"


def test_wrong_type_says_what_was_expected_and_what_came(tmp_path: Path) -> None:
    path = write(tmp_path, "sim:\n  physics_hz: fast\n", name="default.yaml")
    with pytest.raises(
        ConfigError, match=r"default\.yaml: sim\.physics_hz: expected int, got str 'fast'$"
    ):
        load_config(path, Scenario)


def test_missing_required_keys_are_errors(tmp_path: Path) -> None:
    assert load_error(tmp_path, "sim: {speed: 2.0}\n").endswith(
        "sim.physics_hz: missing required key (expected int)"
    )
    assert load_error(tmp_path, "seed: 3\n").endswith(
        "sim: missing required key (expected SimConfig)"
    )


@pytest.mark.parametrize(
    ("snippet", "message"),
    [
        ("physics_hz: true", "sim.physics_hz: expected int, got bool True"),
        ("physics_hz: 400.0", "sim.physics_hz: expected int, got float 400.0"),
        ("{physics_hz: 400, speed: false}", "sim.speed: expected float, got bool False"),
        ("{physics_hz: 400, speed: .nan}", "sim.speed: expected a finite float, got nan"),
        ("{physics_hz: 400, speed: -.inf}", "sim.speed: expected a finite float, got -inf"),
        ("{physics_hz: 400, lockstep: 1}", "sim.lockstep: expected bool, got int 1"),
        ("{physics_hz: 400, name: 12}", "sim.name: expected str, got int 12"),
        (
            "{physics_hz: 400, key_file: ''}",
            "sim.key_file: expected a path (non-empty str), got str ''",
        ),
    ],
)
def test_scalars_are_strict(tmp_path: Path, snippet: str, message: str) -> None:
    text = f"sim: {snippet}\n" if snippet.startswith("{") else f"sim:\n  {snippet}\n"
    assert load_error(tmp_path, text).endswith(message)


def test_tuple_length_and_element_errors(tmp_path: Path) -> None:
    short = load_error(tmp_path, "sim: {physics_hz: 400, offset_enu_m: [1, 2]}\n")
    assert short.endswith("sim.offset_enu_m: expected 3 items (tuple[float, float, float]), got 2")
    bad = load_error(tmp_path, "sim: {physics_hz: 400, offset_enu_m: [1, x, 3]}\n")
    assert bad.endswith("sim.offset_enu_m[1]: expected float, got str 'x'")
    scalar = load_error(tmp_path, "sim: {physics_hz: 400, offset_enu_m: 5}\n")
    assert scalar.endswith(
        "sim.offset_enu_m: expected list (tuple[float, float, float]), got int 5"
    )
    nested = load_error(
        tmp_path, "sim: {physics_hz: 400}\ngcs: {imm: {transition: [[1, 0], [1]]}}\n"
    )
    assert nested.endswith("gcs.imm.transition[1]: expected 2 items (tuple[float, float]), got 1")


def test_literal_and_enum(tmp_path: Path) -> None:
    literal = load_error(tmp_path, "sim: {physics_hz: 400}\ngcs: {method: gn}\n")
    assert literal.endswith("gcs.method: expected one of 'trf', 'lm', got str 'gn'")
    enum_bad = load_error(tmp_path, "sim: {physics_hz: 400}\ngcs: {imm: {first_mode: cx}}\n")
    assert enum_bad.endswith("gcs.imm.first_mode: expected a Mode (CV='cv', CA='ca'), got str 'cx'")
    by_value = from_mapping(GcsConfig, {"imm": {"first_mode": "ca"}}, "x.yaml")
    assert by_value.imm.first_mode is Mode.CA
    # an int-valued enum takes 2 but not True, and a bool literal never matches 1
    assert from_mapping(RadioConfig, {"gain_db": 0, "level": 2}, "x").level is Level.HIGH
    with pytest.raises(ConfigError, match=r"radios\.a\.level: expected a Level"):
        from_mapping(
            Scenario,
            {"sim": {"physics_hz": 400}, "radios": {"a": {"gain_db": 0, "level": True}}},
            "x",
        )


def test_post_init_field_error_is_wrapped_with_file_and_path(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        "sim: {physics_hz: 400}\ngcs:\n  imm:\n    transition: [[0.98, 0.02], [0.16, 0.81]]\n",
        name="paper.yaml",
    )
    with pytest.raises(ConfigError) as info:
        load_config(path, Scenario)
    assert str(info.value) == f"{path}: gcs.imm.transition[1]: row sums to 0.97, must be 1"
    assert isinstance(info.value.__cause__, FieldValueError)


def test_post_init_plain_value_error_is_reported_at_the_dataclass_path(tmp_path: Path) -> None:
    message = load_error(tmp_path, "sim: {physics_hz: 250}\n")
    assert message.endswith(
        "scenario.yaml: sim: physics_hz 250 is not a multiple of controller_hz 100"
    )


@pytest.mark.parametrize(
    ("text", "line"),
    [
        ("sim:\n  physics_hz: 400 controller_hz: 100\n", 2),
        ("sim:\n  physics_hz: [400, 100\ngcs: {}\n", 3),
        ("sim: {physics_hz: 400}\nseed: 1\nseed: 2\n", 3),  # duplicate keys are errors too
    ],
)
def test_yaml_syntax_errors_name_file_and_line(tmp_path: Path, text: str, line: int) -> None:
    message = load_error(tmp_path, text)
    assert re.match(rf".*scenario\.yaml: line {line}, column \d+: YAML syntax error: ", message)


def test_yaml_merge_keys_may_be_overridden(tmp_path: Path) -> None:
    text = "sim: {physics_hz: 400}\nradios:\n  a: &b {gain_db: 1.0}\n  b: {<<: *b, gain_db: 3}\n"
    loaded = load_config(write(tmp_path, text), Scenario)
    assert loaded.radios["a"].gain_db == 1.0
    assert loaded.radios["b"].gain_db == 3.0


def test_top_level_must_be_a_mapping(tmp_path: Path) -> None:
    assert load_error(tmp_path, "- 1\n").endswith("expected mapping (Scenario), got list [1]")
    assert load_error(tmp_path, "").endswith("expected mapping (Scenario), got null")


def test_missing_file_is_a_config_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"nope\.yaml: cannot read configuration file"):
        load_config(tmp_path / "nope.yaml", Scenario)


def test_dict_entries_are_paths_and_keys_must_be_strings() -> None:
    data = {"sim": {"physics_hz": 400}, "radios": {"rx1": {"gain_db": "high"}}}
    with pytest.raises(
        ConfigError, match=r"^f\.yaml: radios\.rx1\.gain_db: expected float, got str 'high'$"
    ):
        from_mapping(Scenario, data, "f.yaml")
    with pytest.raises(ConfigError, match="radios: expected str keys, got int 1"):
        from_mapping(
            Scenario, {"sim": {"physics_hz": 400}, "radios": {1: {"gain_db": 0}}}, "f.yaml"
        )


def test_unsupported_annotation_is_a_programming_error() -> None:
    with pytest.raises(TypeError, match="unsupported field annotation"):
        from_mapping(Unsupported, {"values": [1]}, "x")


def test_overrides_apply_dotted_keys_and_validate() -> None:
    cfg = from_mapping(
        Scenario, {"sim": {"physics_hz": 400}, "radios": {"rx1": {"gain_db": 1}}}, "x"
    )
    new = with_overrides(
        cfg,
        {
            "sim.speed": 5,
            "gcs.imm.first_mode": "CA",
            "sim.offset_enu_m": [1, 2, 3],
            "radios.rx1.gain_db": 4,
        },
    )
    assert new.sim.speed == 5.0
    assert new.gcs.imm.first_mode is Mode.CA
    assert new.sim.offset_enu_m == (1.0, 2.0, 3.0)
    assert new.radios["rx1"].gain_db == 4.0
    assert cfg.sim.speed == 1.0 and cfg.radios["rx1"].gain_db == 1.0  # the original is untouched
    assert new.gcs.imm.transition == cfg.gcs.imm.transition


def test_overrides_of_one_dataclass_are_applied_together() -> None:
    cfg = from_mapping(Scenario, {"sim": {"physics_hz": 400}}, "x")
    # 250 Hz alone is not a multiple of 100 Hz; together with 50 Hz it is valid.
    new = with_overrides(cfg, {"sim.physics_hz": 250, "sim.controller_hz": 50})
    assert (new.sim.physics_hz, new.sim.controller_hz) == (250, 50)
    with pytest.raises(ConfigError, match=r"^override: sim: physics_hz 250 is not a multiple"):
        with_overrides(cfg, {"sim.physics_hz": 250})


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        (
            {"sim.phisics_hz": 1},
            "override: sim.phisics_hz: unknown key (known: physics_hz, controller_hz",
        ),
        ({"sim.physics_hz": "fast"}, "override: sim.physics_hz: expected int, got str 'fast'"),
        (
            {"gcs.imm.transition": [[0.5, 0.4]]},
            "override: gcs.imm.transition[0]: row sums to 0.90, must be 1",
        ),
        ({"sim.speed.x": 1.0}, "override: sim.speed.x: cannot set keys inside float 1.0"),
        ({"radios.rx9.gain_db": 1.0}, "override: radios.rx9: unknown key (known: )"),
        (
            {"sim": {"physics_hz": 100}, "sim.speed": 2.0},
            "override: sim.speed: conflicts with the override of sim",
        ),
        (
            {"sim.speed": 2.0, "sim": {"physics_hz": 100}},
            "override: sim: conflicts with overrides of keys inside it",
        ),
        ({"sim..speed": 2.0}, "override: sim..speed: malformed override key"),
    ],
)
def test_bad_overrides_are_rejected(overrides: dict[str, object], message: str) -> None:
    cfg = from_mapping(Scenario, {"sim": {"physics_hz": 400}}, "x")
    with pytest.raises(ConfigError) as info:
        with_overrides(cfg, overrides)
    assert str(info.value).startswith(message)


def test_override_can_replace_a_whole_section_and_add_a_dict_entry() -> None:
    cfg = from_mapping(Scenario, {"sim": {"physics_hz": 400, "speed": 3.0}}, "x")
    new = with_overrides(cfg, {"sim": {"physics_hz": 200}, "radios.rx2": {"gain_db": 1}})
    assert new.sim == SimConfig(physics_hz=200)  # replaced, so speed is back to its default
    assert new.radios == {"rx2": RadioConfig(gain_db=1.0)}


def test_parse_override_reads_yaml_values() -> None:
    assert parse_override("sim.speed=5.0") == ("sim.speed", 5.0)
    assert parse_override("sim.name=fast") == ("sim.name", "fast")
    assert parse_override(" sim.offset_enu_m = [1, 2, 3]") == ("sim.offset_enu_m", [1, 2, 3])
    assert parse_override("seed=") == ("seed", None)
    with pytest.raises(ConfigError, match=r"expected KEY=VALUE, got 'sim\.speed'"):
        parse_override("sim.speed")


def test_to_mapping_round_trips(tmp_path: Path) -> None:
    cfg = load_config(write(tmp_path, GOOD_YAML), Scenario)
    plain = to_mapping(cfg)
    assert plain["radios"] == {
        "rx1": {"gain_db": 2.15, "level": 2},
        "rx2": {"gain_db": 0.0, "level": 1},
    }
    assert from_mapping(Scenario, plain, "round trip") == cfg
