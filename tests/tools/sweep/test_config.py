"""The sweep's matrix as configuration (``sweep.config``): the ``sweep:`` section and its
checks, seed ranges, parameter axes and how their values name run folders."""

from __future__ import annotations

from pathlib import Path

import pytest

from ridsafe.common.config import from_mapping, to_mapping
from ridsafe.common.errors import ConfigError, FieldValueError
from ridsafe.tools.run.scenario import REPO_ROOT, ScenarioFile, load_scenario_file
from ridsafe.tools.sweep.config import ParamAxis, SweepConfig, format_value, parse_seeds

PAPER = REPO_ROOT / "configs" / "paper.yaml"


@pytest.mark.parametrize(
    ("text", "seeds"),
    [("0:3", (0, 1, 2)), ("5", (5,)), ("0,7,3", (0, 7, 3)), ("0:2, 10:12", (0, 1, 10, 11))],
)
def test_seed_ranges(text: str, seeds: tuple[int, ...]) -> None:
    assert parse_seeds(text) == seeds


@pytest.mark.parametrize("text", ["", "3:1", "-1", "0,0", "a:b", "1:2:3"])
def test_bad_seed_ranges_are_rejected(text: str) -> None:
    with pytest.raises(ValueError, match="seeds"):
        parse_seeds(text)


def test_the_defaults_are_the_papers_matrix() -> None:
    config = SweepConfig()
    assert config.densities == (4, 8, 12, 16)
    assert config.seed_values == tuple(range(30))
    assert config.planners == ("aware", "trust-rid")
    assert config.duration_s is None and config.params == {}
    assert config.foxglove_channels is False  # sweep logs leave the derived views out


def test_seeds_as_a_list_or_as_text_are_the_same_matrix() -> None:
    assert SweepConfig(seeds=(3, 1, 2)).seed_values == (3, 1, 2)
    assert SweepConfig(seeds="3,1:3").seed_values == (3, 1, 2)


@pytest.mark.parametrize(
    ("kwargs", "field", "reason"),
    [
        ({"densities": ()}, "densities", "at least one"),
        ({"densities": (4, 4)}, "densities", "distinct"),
        ({"densities": (4, 0)}, r"densities\[1\]", ">= 1 aircraft"),
        ({"seeds": "2:1"}, "seeds", "seeds"),
        ({"seeds": (0, 0)}, "seeds", "distinct"),
        ({"planners": ("aware", "nope")}, r"planners\[1\]", "unknown planner 'nope'"),
        ({"planners": ("aware", "aware")}, "planners", "distinct"),
        ({"duration_s": 0.0}, "duration_s", "> 0"),
        ({"params": {"bad name": ParamAxis(("a.b",), (1,))}}, "params.bad name", "letters"),
    ],
)
def test_a_bad_matrix_names_the_field(kwargs: dict[str, object], field: str, reason: str) -> None:
    with pytest.raises(FieldValueError, match=f"^{field}: .*{reason}"):
        SweepConfig(**kwargs)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("keys", "values", "field", "reason"),
    [
        ((), (1,), "keys", "at least one"),
        (("scenario.seed",), (1, 2), r"keys\[0\]", "axis of the sweep itself"),
        (("a.b", "scenario.aircraft"), (1,), r"keys\[1\]", "axis of the sweep itself"),
        (("a.b",), (), "values", "at least one"),
        (("a.b",), (0.1, 0.1), r"values\[1\]", "distinct, path-safe"),
        (("a.b",), ("x/y",), r"values\[0\]", "path-safe"),
    ],
)
def test_a_bad_axis_names_the_field(
    keys: tuple[str, ...], values: tuple[object, ...], field: str, reason: str
) -> None:
    with pytest.raises(FieldValueError, match=f"^{field}: .*{reason}"):
        ParamAxis(keys, values)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("value", "text"),
    [(True, "true"), (False, "false"), (3, "3"), (0.05, "0.05"), (1.0, "1.0"), ("fast", "fast")],
)
def test_values_name_run_folders_unambiguously(value: bool | int | float | str, text: str) -> None:
    assert format_value(value) == text


def test_a_float_and_an_int_axis_value_are_told_apart() -> None:
    axis = ParamAxis(("pipeline.region.alpha",), (1, 1.0))  # "1" and "1.0": two folders
    assert [format_value(v) for v in axis.values] == ["1", "1.0"]


def test_the_section_round_trips_through_yaml(tmp_path: Path) -> None:
    path = tmp_path / "with_sweep.yaml"
    path.write_text(
        PAPER.read_text() + "\nsweep:\n  densities: [4, 8]\n  seeds: '0:3'\n"
        "  duration_s: 30.0\n  foxglove_channels: true\n  params:\n"
        "    rssi:\n      keys: [scenario.radio.shadowing_sigma_db, pipeline.rssi_sigma_db]\n"
        "      values: [1.0, 2.0]\n"
    )
    loaded = load_scenario_file(path)
    assert loaded.sweep == SweepConfig(
        densities=(4, 8),
        seeds="0:3",
        duration_s=30.0,
        foxglove_channels=True,
        params={
            "rssi": ParamAxis(
                ("scenario.radio.shadowing_sigma_db", "pipeline.rssi_sigma_db"), (1.0, 2.0)
            )
        },
    )
    again = from_mapping(ScenarioFile, to_mapping(loaded), "again")
    assert again.sweep == loaded.sweep


def _with(tmp_path: Path, section: str) -> Path:
    path = tmp_path / "section.yaml"
    path.write_text(PAPER.read_text() + "\nsweep:\n" + section + "\n")
    return path


def test_errors_in_the_section_name_file_and_key_path(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"section\.yaml: sweep.*densitys"):
        load_scenario_file(_with(tmp_path, "  densitys: [4]"))
    with pytest.raises(ConfigError, match=r"section\.yaml: sweep\.params\.a\.values"):
        load_scenario_file(_with(tmp_path, "  params: {a: {keys: [x.y], values: 3}}"))
    with pytest.raises(ConfigError, match=r"section\.yaml: sweep\.densities\[0\]: expected >= 1"):
        load_scenario_file(_with(tmp_path, "  densities: [0]"))
