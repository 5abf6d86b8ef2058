"""Synthetic labelled links for the channel-fit tests: who heard whom, how far apart."""

from __future__ import annotations

import numpy as np


def random_links(
    rng: np.random.Generator, n: int, k: int, level_db: float, distance_range_m: tuple[float, float]
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(levels (n,), transmitter ids (k,), receiver ids (k,), distances (k,)): ``n``
    aircraft with levels N(level_db, 1), ``k`` receptions between two different ones (ids
    1..n) at uniform distances, drawn in that order from ``rng``."""
    level = level_db + rng.normal(0.0, 1.0, n)
    tx = rng.integers(1, n + 1, k)
    rx = (tx + rng.integers(1, n, k) - 1) % n + 1
    d = rng.uniform(*distance_range_m, k)
    return level, tx, rx, d
