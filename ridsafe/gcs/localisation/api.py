"""What a track needs from an estimator, and how the configured estimator is found.

A track (``gcs/tracks.py``) holds one ``Localiser`` per alerted transmitter: started by the
estimator's ``StartLocaliser`` from the transmitter's recent observed claims, updated with
every later claim, asked for its prediction every cycle. Which estimator: the name in
``pipeline.estimator``, looked up in ``registry.ESTIMATORS`` (how to add one: there).
"""

from __future__ import annotations

import functools
import importlib
import math
from collections.abc import Sequence
from typing import Protocol, cast

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.errors import FieldValueError
from ridsafe.gcs.localisation.registry import ESTIMATORS, check_estimator
from ridsafe.gcs.pipeline_api import ObservedClaim
from ridsafe.gcs.pipeline_config import PipelineConfig
from ridsafe.gcs.tracking.imm import Gaussian

FloatArray = NDArray[np.float64]

__all__ = ["Localiser", "StartLocaliser", "estimator_start"]


class Localiser(Protocol):
    """One transmitter's state estimate, fed with its observed claims."""

    def update(self, claim: ObservedClaim) -> bool:
        """Use one observed claim (True when it updated the estimate)."""
        ...

    def predicted(self, t_s: float) -> tuple[Gaussian, FloatArray]:
        """(fused estimate, a batch of 1 in CV order: p, v[, extras]; mode probabilities
        (2,)) at ``t_s``, without advancing the stored state."""
        ...


class StartLocaliser(Protocol):
    """Start a localiser from ``claims`` (oldest first): (it, how many of the claims it
    consumed), or None when none of them can start one yet. Claims up to ``after_s`` were
    tried already (an estimator may skip them)."""

    def __call__(
        self, claims: Sequence[ObservedClaim], cfg: PipelineConfig, after_s: float = -math.inf
    ) -> tuple[Localiser, int] | None: ...


def estimator_start(name: str) -> StartLocaliser:
    """The start function registered as ``name`` (``registry.ESTIMATORS``); a
    ``FieldValueError`` on ``estimator`` when the name is unknown or its entry does not load."""
    check_estimator(name)
    return _load(name, ESTIMATORS[name])


@functools.cache
def _load(name: str, entry_point: str) -> StartLocaliser:
    module_name, _, attribute = entry_point.partition(":")
    try:
        start = getattr(importlib.import_module(module_name), attribute)
    except (ImportError, AttributeError) as exc:
        raise FieldValueError(
            "estimator", f"{name!r} is registered as {entry_point!r}, which does not load: {exc}"
        ) from exc
    if not callable(start):
        raise FieldValueError(
            "estimator", f"{name!r} is registered as {entry_point!r}, which is not callable"
        )
    return cast(StartLocaliser, start)
