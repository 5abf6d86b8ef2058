"""Configuration reading holds against hostile files (issue 14): libyaml's parser where
available, a size limit with a clear error, an empty aircraft list refused at its key."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
import yaml

from ridsafe.common import config
from ridsafe.common.errors import ConfigError
from ridsafe.tools.run.scenario import ScenarioFile, load_scenario_file, resolve_config_path


def test_the_c_loader_is_used_when_pyyaml_has_it() -> None:
    if not yaml.__with_libyaml__:
        pytest.skip("PyYAML built without libyaml")
    assert issubclass(config._StrictLoader, yaml.CSafeLoader)


def test_duplicate_keys_are_still_refused_with_the_c_loader() -> None:
    with pytest.raises(ConfigError, match="duplicate key 'a'"):
        config.parse_yaml("a: 1\na: 2\n", "dup.yaml")


def test_a_file_over_the_size_limit_is_refused_before_parsing(tmp_path: Path) -> None:
    big = tmp_path / "big.yaml"
    big.write_text("x: " + "a" * (10 * config.MAX_CONFIG_BYTES) + "\n", encoding="utf-8")
    start = time.perf_counter()
    with pytest.raises(ConfigError, match=r"big.yaml: .*bytes, more than the 1048576 allowed"):
        config.load_config(big, ScenarioFile)
    assert time.perf_counter() - start < 1.0


def test_an_override_text_over_the_limit_is_refused() -> None:
    with pytest.raises(ConfigError, match="more than the"):
        config.parse_yaml("a" * (config.MAX_CONFIG_BYTES + 1), "--set x")


def test_an_empty_aircraft_list_is_refused_naming_its_key_path(tmp_path: Path) -> None:
    text = resolve_config_path(None).read_text(encoding="utf-8")
    data = yaml.safe_load(text)
    data["scenario"]["aircraft"] = []
    empty = tmp_path / "empty.yaml"
    empty.write_text(yaml.safe_dump(data), encoding="utf-8")
    with pytest.raises(ConfigError, match=r"empty.yaml: scenario.aircraft: .*at least one"):
        load_scenario_file(empty)
