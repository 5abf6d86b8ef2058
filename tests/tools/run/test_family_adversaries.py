"""The family's adversaries: drawn per seed (counts and kinds as family keys), never from the
run's duration; ``--set scenario.spoofer.*`` with ``--aircraft`` applied or an error."""

from __future__ import annotations

import argparse
import dataclasses

import pytest

from ridsafe.common.errors import ConfigError
from ridsafe.tools.cli import run_cmd
from ridsafe.tools.run.family_adversaries import AdversaryDraw
from ridsafe.tools.run.scenario import (
    ScenarioFile,
    check_no_drawn_overrides,
    load_scenario_file,
)
from ridsafe.tools.run.scenario_family import FamilyConfig, generate

BASE = load_scenario_file().scenario


def _effective(*argv: str) -> ScenarioFile:
    parser = argparse.ArgumentParser()
    run_cmd.register(parser.add_subparsers())
    return run_cmd.effective_scenario(parser.parse_args(["run", *argv]))


def test_a_spoofer_override_is_applied_to_the_family_drawn_spoofer() -> None:
    scenario = _effective("--aircraft", "16", "--set", "scenario.spoofer.tx_power_dbm=30").scenario
    assert scenario.spoofer is not None and scenario.spoofer.tx_power_dbm == 30.0
    assert scenario.tx_power_dbm_of(17) == 30.0
    plain = _effective("--aircraft", "16").scenario
    assert plain.spoofer is not None
    assert dataclasses.replace(scenario.spoofer, tx_power_dbm=None) == plain.spoofer


def test_an_override_the_drawn_scenario_cannot_take_is_an_error() -> None:
    with pytest.raises(ConfigError, match=r"scenario\.aircraft"):
        _effective("--aircraft", "4", "--set", "scenario.aircraft=[]")
    with pytest.raises(ConfigError, match=r"scenario\.spoofers"):
        _effective(
            "--aircraft", "4",
            "--set", "family.adversaries.spoofer_count=2",
            "--set", "scenario.spoofer.tx_power_dbm=30",
        )  # fmt: skip
    loaded = load_scenario_file()
    with pytest.raises(ConfigError, match="family"):
        check_no_drawn_overrides(loaded, {"scenario.spoofer.tx_power_dbm": 30.0})


def test_the_drawn_spoofer_does_not_depend_on_the_duration() -> None:
    family = FamilyConfig()
    for seed in range(4):
        long = generate(BASE, 16, seed, family)
        short = generate(dataclasses.replace(BASE, duration_s=30.0), 16, seed, family)
        assert short.spoofer == long.spoofer
    assert _effective("--aircraft", "16", "--duration", "40").scenario.spoofer == (
        _effective("--aircraft", "16").scenario.spoofer
    )


def test_the_family_draws_counts_and_kinds_per_seed() -> None:
    draw = AdversaryDraw(
        spoofer_count=3,
        motions=("pursue", "orbit", "waypoints"),
        claims=("drift", "mimic", "fixed"),
        tx_power_kind="random",
        ghost_count=2,
    )
    family = FamilyConfig(adversaries=draw)
    seen: set[tuple[str, str]] = set()
    for seed in range(6):
        s = generate(BASE, 8, seed, family)
        assert s.spoofer is None and len(s.spoofers) == 3 and len(s.ghosts) == 2
        assert generate(BASE, 8, seed, family) == s  # the same seed, the same adversaries
        for spoofer in s.spoofers:
            seen.add((spoofer.resolved_motion.kind, spoofer.resolved_claim.kind))
            assert spoofer.tx_power is not None and spoofer.tx_power.sigma_db == 6.0
        for ghost in s.ghosts:
            assert ghost.transmitter_enu_m[2] == 2.0 and ghost.claim.kind == "waypoints"
    assert {m for m, _ in seen} == {"pursue", "orbit", "waypoints"}
    assert {c for _, c in seen} == {"drift", "mimic", "fixed"}
    # spoofer k's draw does not move when the count changes
    one = generate(
        BASE,
        8,
        3,
        dataclasses.replace(family, adversaries=dataclasses.replace(draw, spoofer_count=1)),
    )
    assert one.spoofers[0] == generate(BASE, 8, 3, family).spoofers[0]


def test_the_default_draw_is_the_one_aimed_spoofer_as_before() -> None:
    assert AdversaryDraw().is_default
    s = generate(BASE, 16, 0, FamilyConfig())
    assert s.spoofer is not None and not s.spoofers and not s.ghosts
    assert s.spoofer.motion is None and s.spoofer.start_enu_m is not None


def test_a_wrong_family_adversary_key_names_its_path() -> None:
    with pytest.raises(ConfigError, match=r"family.adversaries.motions\[0\]"):
        load_scenario_file(overrides={"family.adversaries.motions": ["teleport"]})
