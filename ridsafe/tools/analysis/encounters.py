"""Encounters counted as events: the one home of NMAC and region-entry counting.

Used by the run metrics (``analysis.metrics``, from a run log's truth) and by the planner-only
closed loop (``tools.planner_loop``, from its own world), so both count alike.

Airborne. An aircraft counts as airborne at a sample when it is armed and its true height
``z_enu >= min_height_m`` (the metrics use 1 m; depots and delivery sites are at z = 0).
Aircraft sharing a depot start metres apart on the ground; pairs with an aircraft on the
ground are no encounter.

Entry events. For one pair (or one aircraft and one ellipsoid), a sample is *inside*
(distance ``d < d_nmac``, or the aircraft inside the ellipsoid) or *separated*
(``d >= d_nmac``, or outside); NaN is neither. A run of samples between two separated samples
is one episode; the episode is one event if at some sample of it the pair is inside and
eligible (both airborne). So a pass at 40 m is one event however many samples it spans, and
approach - separate - re-approach is two. (Two aircraft that take off together less than
``d_nmac`` apart count once, when both are above ``min_height_m``.) With
``separated = ~inside`` an event is simply each run of inside samples.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "airborne",
    "count_entries",
    "count_entry_events",
    "entry_event_samples",
    "pair_entry_events",
    "pair_masks",
]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
IntArray = NDArray[np.int64]

#: Pairs per block in the pairwise distance computation (bounds memory for 256 aircraft).
_PAIR_BLOCK = 2048


def count_entry_events(inside: BoolArray, separated: BoolArray) -> IntArray:
    """Entry events per column of (T, P) sample masks (see the module docstring).

    ``inside[k, p]``: sample k of pair p counts as a violation (inside and eligible);
    ``separated[k, p]``: the pair is apart at sample k (ends an episode). Returns (P,).
    """
    n_samples, n_pairs = inside.shape
    episode = np.cumsum(separated, axis=0)
    k, pair = np.nonzero(inside)
    keys = np.unique(pair.astype(np.int64) * (n_samples + 1) + episode[k, pair])
    return np.bincount(keys // (n_samples + 1), minlength=n_pairs).astype(np.int64)


def entry_event_samples(inside: BoolArray, separated: BoolArray) -> list[IntArray]:
    """The events of one pair's (T,) sample masks, in time order, each as the indices of its
    inside samples: ``len`` of the result is :func:`count_entry_events` of that column."""
    episode = np.cumsum(separated)
    k = np.flatnonzero(inside)
    if k.size == 0:
        return []
    starts = np.flatnonzero(np.diff(episode[k])) + 1
    return [part.astype(np.int64) for part in np.split(k, starts)]


def count_entries(inside: BoolArray) -> int:
    """Total entry events of (T, ...) samples where outside means separated: the number of
    runs of inside samples, summed over every pair (a run may start at sample 0)."""
    flat = inside.reshape(inside.shape[0], -1)
    return int(count_entry_events(flat, ~flat).sum())


def airborne(p_enu_m: FloatArray, armed: BoolArray, min_height_m: float) -> BoolArray:
    """(..., N) mask: armed and true height >= ``min_height_m`` (NaN height: not airborne)."""
    with np.errstate(invalid="ignore"):
        return armed & (p_enu_m[..., 2] >= min_height_m)


def pair_entry_events(
    p: FloatArray, flying: BoolArray, i: IntArray, j: IntArray, threshold_m: float
) -> int:
    """NMAC entry events summed over the pairs (i[k], j[k]) of columns of ``p`` (T, N, 3),
    a pair inside when closer than ``threshold_m`` and both ``flying`` (T, N)."""
    total = 0
    for start in range(0, i.size, _PAIR_BLOCK):
        ii, jj = i[start : start + _PAIR_BLOCK], j[start : start + _PAIR_BLOCK]
        _d, inside, separated = pair_masks(p, flying, ii, jj, threshold_m)
        total += int(count_entry_events(inside, separated).sum())
    return total


def pair_masks(
    p: FloatArray, flying: BoolArray, i: IntArray, j: IntArray, threshold_m: float
) -> tuple[FloatArray, BoolArray, BoolArray]:
    """For the pairs (i[k], j[k]) of columns of ``p`` (T, N, 3): their 3D distance (T, K),
    inside (closer than ``threshold_m`` with both ``flying``) and separated (T, K): the masks
    :func:`count_entry_events` and :func:`entry_event_samples` take."""
    d = np.linalg.norm(p[:, i] - p[:, j], axis=-1)
    with np.errstate(invalid="ignore"):
        inside = (d < threshold_m) & flying[:, i] & flying[:, j]
        separated = d >= threshold_m
    return d, inside, separated
