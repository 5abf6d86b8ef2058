"""Random streams derived from the scenario seed.

Every stochastic part of a run takes its own ``numpy.random.Generator`` spawned from the
scenario seed and a stream name, so adding a consumer never shifts another's draws and a
lockstep run is bit-reproducible::

    SeedSequence(entropy=seed, spawn_key=(crc32(stream),))
"""

from __future__ import annotations

import zlib

import numpy as np


def stream(seed: int, name: str) -> np.random.Generator:
    """The generator of stream ``name`` (e.g. ``"radio"``, ``"companion/3"``) for ``seed``."""
    key = zlib.crc32(name.encode("utf-8"))
    return np.random.default_rng(np.random.SeedSequence(entropy=seed, spawn_key=(key,)))
