"""Entry events (``analysis.encounters``), the one NMAC and region-entry count shared by the
run metrics and the planner-only closed loop: hand-worked masks, and a differential test
against a sample-by-sample counter written here."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import NDArray

from ridsafe.tools.analysis import encounters
from ridsafe.tools.analysis.encounters import (
    airborne,
    count_entries,
    count_entry_events,
    pair_entry_events,
)

BoolArray = NDArray[np.bool_]


def streaming_entries(inside: BoolArray) -> int:
    """The closed loop's old rule, sample by sample: an entry is inside after not inside."""
    previous = np.zeros(inside.shape[1:], dtype=bool)
    count = 0
    for sample in inside:
        count += int(np.count_nonzero(sample & ~previous))
        previous = sample
    return count


def test_count_entry_events_counts_episodes_not_samples() -> None:
    inside = np.array([[0, 0, 1], [1, 0, 1], [1, 0, 0], [0, 0, 0], [1, 0, 1]], dtype=bool)
    separated = np.array([[1, 1, 0], [0, 1, 0], [0, 1, 1], [1, 1, 0], [0, 1, 0]], dtype=bool)
    # pair 0: inside at 1-2 (one episode), separated at 3, inside at 4: 2 events
    # pair 1: never inside; pair 2: inside at 0-1, separated at 2, inside at 4: 2 events
    assert count_entry_events(inside, separated).tolist() == [2, 0, 2]


def test_neither_inside_nor_separated_does_not_end_an_episode() -> None:
    """NaN distance (or a pair on the ground) between two inside samples: one event."""
    inside = np.array([[1], [0], [1]], dtype=bool)
    assert count_entry_events(inside, np.zeros_like(inside)).tolist() == [1]
    assert count_entry_events(inside, ~inside).tolist() == [2]


@pytest.mark.parametrize("seed", range(5))
def test_count_entries_is_the_sample_by_sample_rule(seed: int) -> None:
    rng = np.random.default_rng(seed)
    inside = rng.random((300, 6, 6)) < rng.uniform(0.05, 0.6)
    assert count_entries(inside) == streaming_entries(inside)


def test_an_entry_at_the_first_sample_counts() -> None:
    assert count_entries(np.array([[True, False], [True, True]])) == 2


def test_airborne_needs_armed_and_height_and_a_known_position() -> None:
    p = np.array([[0.0, 0.0, 0.5], [0.0, 0.0, 1.0], [0.0, 0.0, math.nan], [0.0, 0.0, 60.0]])
    armed = np.array([True, True, True, False])
    assert airborne(p, armed, 1.0).tolist() == [False, True, False, False]


def test_pair_events_are_the_same_in_blocks_as_pair_by_pair(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    rng = np.random.default_rng(11)
    p = rng.uniform(-60.0, 60.0, size=(120, 7, 3))
    p[40:45, 2] = math.nan  # a lost aircraft is neither inside nor separated
    flying = rng.random((120, 7)) < 0.9
    i, j = np.triu_indices(7, k=1)
    whole = pair_entry_events(p, flying, i, j, 50.0)
    pair_by_pair = sum(
        pair_entry_events(p, flying, i[k : k + 1], j[k : k + 1], 50.0) for k in range(i.size)
    )
    monkeypatch.setattr(encounters, "_PAIR_BLOCK", 4)  # 21 pairs in 6 blocks
    assert pair_entry_events(p, flying, i, j, 50.0) == whole == pair_by_pair > 0


def test_entry_event_samples_lists_each_event_s_inside_samples() -> None:
    inside = np.array([0, 1, 1, 0, 0, 1, 0, 1], dtype=bool)
    separated = np.array([1, 0, 0, 1, 0, 0, 0, 0], dtype=bool)
    # inside 1-2, separated at 3, inside 5 and 7 with nothing apart between them: two events
    events = encounters.entry_event_samples(inside, separated)
    assert [e.tolist() for e in events] == [[1, 2], [5, 7]]


@pytest.mark.parametrize("seed", range(5))
def test_entry_event_samples_are_as_many_as_counted(seed: int) -> None:
    """Differential: the listing and the counter agree on every column of random masks."""
    rng = np.random.default_rng(seed)
    inside = rng.random((400, 8)) < rng.uniform(0.05, 0.6)
    separated = ~inside & (rng.random((400, 8)) < 0.5)
    counts = count_entry_events(inside, separated)
    for column in range(8):
        events = encounters.entry_event_samples(inside[:, column], separated[:, column])
        assert len(events) == counts[column]
        listed = np.concatenate(events) if events else np.zeros(0, dtype=np.int64)
        assert listed.tolist() == np.flatnonzero(inside[:, column]).tolist()
