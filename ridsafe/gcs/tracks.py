"""Spoofer tracks: initiation on alert, update, coasting, deletion when the transmitter is silent.

Life of a track (one per alerted uas_id):

- **initiation**: when the uas_id is alerted, from its observed claims of the last
  ``backfill_s`` seconds (the pipeline keeps them for the detectors anyway): the configured
  estimator (``pipeline.estimator``, looked up in ``localisation/registry.py``) starts its
  localiser from the first claims that allow it, the later ones update it in order. None
  allows it yet (too few receivers): the pipeline tries again next cycle.
- **update**: every later claim of that uas_id, at its reception time.
- **coasting**: between claims (and when one is rejected) the estimate is only
  predicted, to the cycle time, with F and Q over the real interval; ``TrackEstimate.fix`` is
  False on such cycles.
- **deletion**: when nothing was heard from the uas_id for ``silence_timeout_s``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ridsafe.gcs.localisation.api import Localiser, estimator_start
from ridsafe.gcs.pipeline_api import ObservedClaim, TrackEstimate, readonly
from ridsafe.gcs.pipeline_config import PipelineConfig
from ridsafe.gcs.tracking.motion_models import POS, VEL

__all__ = ["Track", "initiate"]


@dataclass
class Track:
    uas_id: str
    track_id: int
    localiser: Localiser
    created_s: float
    last_heard_s: float
    last_fix_s: float
    fixed_this_cycle: bool = False
    n_updates: int = 0

    def update(self, claim: ObservedClaim) -> bool:
        """Update with one observed claim of this track's uas_id (True if it was used)."""
        self.last_heard_s = max(self.last_heard_s, claim.t_s)
        used = self.localiser.update(claim)
        if used:
            self.last_fix_s = claim.t_s
            self.fixed_this_cycle = True
            self.n_updates += 1
        return used

    def silent(self, now_s: float, cfg: PipelineConfig) -> bool:
        return now_s - self.last_heard_s > cfg.tracks.silence_timeout_s

    def estimate(self, now_s: float) -> TrackEstimate:
        """The fused estimate predicted to ``now_s`` (the stored state is not advanced)."""
        fused, mu = self.localiser.predicted(now_s)
        return TrackEstimate(
            uas_id=self.uas_id,
            track_id=self.track_id,
            p_enu_m=readonly(fused.x[0, POS]),
            cov_enu_m2=readonly(fused.P[0, POS, POS]),
            v_enu_m_s=readonly(fused.x[0, VEL]),
            mode_probabilities=readonly(mu),
            fix=self.fixed_this_cycle,
            last_fix_s=self.last_fix_s,
        )


def initiate(
    uas_id: str,
    track_id: int,
    history: Sequence[ObservedClaim],
    cfg: PipelineConfig,
    after_s: float = -float("inf"),
) -> Track | None:
    """A track from ``history`` (oldest first), or None if it cannot start one yet
    (``after_s``: claims up to then were tried already)."""
    started = estimator_start(cfg.estimator)(history, cfg, after_s)
    if started is None:
        return None
    loc, used = started
    first = history[used - 1]
    track = Track(uas_id, track_id, loc, first.t_s, first.t_s, first.t_s, True, 1)
    for claim in history[used:]:
        track.update(claim)
    return track


def finite(est: TrackEstimate) -> bool:
    return bool(np.all(np.isfinite(est.p_enu_m)) and np.all(np.isfinite(est.cov_enu_m2)))
