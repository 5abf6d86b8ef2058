"""The family's adversaries: drawn per seed (counts and kinds as family keys), never from the
run's duration; ``--set scenario.spoofer.*`` with ``--aircraft`` applied or an error."""

from __future__ import annotations

import argparse
import dataclasses
import math

import numpy as np
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


def test_a_bystander_crosses_the_area_telling_the_truth_beside_the_same_spoofer() -> None:
    family = FamilyConfig(adversaries=AdversaryDraw(preset="bystander"))
    r = 1.05 * family.half_width_m
    for seed in range(5):
        plain = generate(BASE, 8, seed, FamilyConfig())
        s = generate(BASE, 8, seed, family)
        assert plain.spoofer is not None and len(s.spoofers) == 2 and not s.ghosts
        spoofer, bystander = s.spoofers
        assert spoofer.role == "spoofer" and bystander.role == "bystander"
        assert spoofer.resolved_motion == plain.spoofer.resolved_motion
        assert spoofer.resolved_claim == plain.spoofer.resolved_claim
        assert bystander.serial == "RSAF800000888" and bystander.resolved_claim.kind == "truth"
        motion = bystander.resolved_motion
        assert motion.kind == "line" and motion.speed_m_s == family.spoofer_speed_m_s
        assert motion.start_enu_m is not None and motion.goal_enu_m is not None
        a, b = np.array(motion.start_enu_m), np.array(motion.goal_enu_m)
        assert np.hypot(*a[:2]) == pytest.approx(r, abs=0.01)
        assert np.hypot(*b[:2]) == pytest.approx(r, abs=0.01)
        assert a[2] == b[2] == family.spoofer_alt_m
        # edge to about the opposite edge: the chord passes within r sin(0.25) of the centre
        (cx, cy), (ax, ay) = b[:2] - a[:2], a[:2]
        assert abs(cx * ay - cy * ax) / math.hypot(cx, cy) <= r * math.sin(0.25) + 0.01
        assert generate(BASE, 8, seed, family) == s


def test_a_wrong_family_adversary_key_names_its_path() -> None:
    with pytest.raises(ConfigError, match=r"family.adversaries.motions\[0\]"):
        load_scenario_file(overrides={"family.adversaries.motions": ["teleport"]})
