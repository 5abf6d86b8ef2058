"""The authors' DepotCity rules: per-seed goal reassignment and the per-N spoofer offset."""

from __future__ import annotations

import dataclasses
import math
import random

from ridsafe.common.scenario import Scenario
from ridsafe.tools.run.depotcity import (
    DepotCityConfig,
    _distance_to_segment_m,
    authors_goal_permutation,
)
from ridsafe.tools.run.scenario import load_scenario_file, with_aircraft

PAPER_LIKE = load_scenario_file("configs/paper_like.yaml")
CFG = DepotCityConfig()


def _sized(n: int, seed: int) -> Scenario:
    loaded = dataclasses.replace(
        PAPER_LIKE, scenario=dataclasses.replace(PAPER_LIKE.scenario, seed=seed)
    )
    return with_aircraft(loaded, n).scenario


def test_paper_like_reassigns_goals_as_a_constrained_derangement_per_seed() -> None:
    assert PAPER_LIKE.depotcity is not None
    listed = [a.goal_enu_m for a in PAPER_LIKE.scenario.aircraft]
    for n in (4, 8, 12, 16):
        seen = set()
        for seed in range(4):
            scenario = _sized(n, seed)
            goals = [a.goal_enu_m for a in scenario.aircraft]
            assert sorted(goals) == sorted(listed[:n])  # the first n goals, permuted
            order = tuple(listed.index(g) for g in goals)
            # A derangement; with 8 or more aircraft the leg and corridor limits almost never
            # hold for every leg at once, so the search ends in its fallback stage, as theirs.
            assert all(i != j for i, j in enumerate(order))
            assert _sized(n, seed) == scenario  # deterministic
            seen.add(order)
        assert len(seen) > 1  # the seed changes the assignment


def test_spoofer_offset_follows_the_number_of_aircraft() -> None:
    offsets = {}
    for n in (8, 16):
        spoofer = _sized(n, 0).spoofer
        assert spoofer is not None
        offsets[n] = spoofer.offset_enu_m
    assert offsets == {8: (0.0, 0.0, 50.0), 16: (100.0, 100.0, 50.0)}


def test_permutation_is_the_first_shuffle_that_fits_in_stage_order() -> None:
    # Four points on a line 400 m apart, the hotspot 300 m off the line: the strict corridor
    # (1 m) never holds, the relaxed one (500 m) holds for the derangements whose legs all
    # are 320-900 m long. The answer is the first of those among the relaxed stage's shuffles,
    # which come after the strict stage's, from one generator seeded with the text.
    starts = [(400.0 * k, 0.0) for k in range(4)]
    hotspot = (600.0, 300.0)
    cfg = DepotCityConfig(min_leg_m=320.0, max_leg_m=900.0, corridor_m=(1.0, 500.0))
    order = authors_goal_permutation(starts, starts, hotspot, "k:3", cfg)
    rng = random.Random("k:3")
    shuffles = []
    for _ in range(2 * cfg.attempts):
        trial = list(range(4))
        rng.shuffle(trial)
        shuffles.append(trial)
    assert not any(_fits_all(o, starts, hotspot, 1.0, cfg) for o in shuffles[: cfg.attempts])
    relaxed = [o for o in shuffles[cfg.attempts :] if _fits_all(o, starts, hotspot, 500.0, cfg)]
    assert relaxed and order == relaxed[0]


def test_impossible_constraints_fall_back_to_a_derangement_then_the_rotation() -> None:
    starts = [(0.0, 0.0), (10.0, 0.0), (20.0, 0.0)]  # every leg shorter than 320 m
    order = authors_goal_permutation(starts, starts, None, "x", CFG)
    assert sorted(order) == [0, 1, 2] and all(i != j for i, j in enumerate(order))
    never = DepotCityConfig(attempts=0, fallback_attempts=0)
    assert authors_goal_permutation(starts, starts, None, "x", never) == [1, 2, 0]


def test_files_without_depotcity_keep_their_goals() -> None:
    plain = dataclasses.replace(PAPER_LIKE, depotcity=None)
    scenario = with_aircraft(plain, 8).scenario
    assert scenario.aircraft == PAPER_LIKE.scenario.aircraft[:8]
    assert scenario.spoofer == PAPER_LIKE.scenario.spoofer


def _fits_all(
    order: list[int],
    starts: list[tuple[float, float]],
    hotspot: tuple[float, float],
    corridor_m: float,
    cfg: DepotCityConfig,
) -> bool:
    for i, j in enumerate(order):
        leg = math.dist(starts[i], starts[j])
        if i == j or not cfg.min_leg_m <= leg <= cfg.max_leg_m:
            return False
        if _distance_to_segment_m(hotspot, starts[i], starts[j]) > corridor_m:
            return False
    return True


def test_paper_like_ours_flies_the_same_scenario_with_default_methods() -> None:
    ours = load_scenario_file("configs/paper_like_ours.yaml")
    assert dataclasses.replace(ours.scenario, name=PAPER_LIKE.scenario.name) == PAPER_LIKE.scenario
    assert ours.depotcity == PAPER_LIKE.depotcity
    assert ours.pipeline == load_scenario_file().pipeline
    assert ours.planner == load_scenario_file().planner
