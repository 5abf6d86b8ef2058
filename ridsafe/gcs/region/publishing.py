r"""Publishing a region: from the estimate (x^_k, P_k) to the region sent (c_k, S_k).

By default the region is the estimate itself (c_k = x^_k, S_k = P_k). With
``pipeline.region.publish.enabled`` it is published the way the authors' code did for the
paper's runs (docs/paper_mode.md, "Region publishing"), per uas_id, every GCS cycle:

    clamp(P)   = V diag(clip(lambda, s_min^2, s_max^2)) V^T        (P = V diag(lambda) V^T)
    P'_k       = clamp(P_k)
    first:       c_k = x^_k,  S_k = P'_k
    after:       d   = x^_k - c_{k-1};  x'_k = c_{k-1} + d * min(1, step_max / |d|)
                 if tr P'_k > g tr S_{k-1}:  P'_k = clamp(P'_k * g tr S_{k-1} / tr P'_k)
                 c_k = (1 - a_c) c_{k-1} + a_c x'_k
                 S_k = clamp((1 - a_S) S_{k-1} + a_S P'_k)

with s_min, s_max = ``std_min_m``, ``std_max_m`` (4, 35 m), step_max = ``max_center_step_m``
(30 m; 0: no limit), g = ``max_trace_growth`` (1.8; 0: no limit), a_c, a_S =
``center_ema_gain``, ``cov_ema_gain`` (0.35, 0.25). The clamp caps the region's largest
semi-axis at sqrt(chi2_3(1 - alpha) s_max^2) (97.8 m at alpha = 0.05 and 35 m) whatever the
estimator says, and the averages make it move slowly: the region no longer means "holds the
spoofer with probability 1 - alpha" (paper eq. (11)); containment is then measured, not owed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ridsafe.gcs.pipeline_config import RegionPublishConfig

FloatArray = NDArray[np.float64]

__all__ = ["Published", "RegionPublisher", "clamp_std", "publish_step"]


@dataclass(frozen=True)
class Published:
    """A published region's centre (3,) and covariance (3, 3), ENU."""

    center_enu_m: FloatArray
    cov_enu_m2: FloatArray


def clamp_std(cov_enu_m2: FloatArray, std_min_m: float, std_max_m: float) -> FloatArray:
    """``cov`` symmetrised, its eigenvalues clipped to [std_min^2, std_max^2]."""
    sym = 0.5 * (cov_enu_m2 + cov_enu_m2.T)
    lam, V = np.linalg.eigh(sym)
    out: FloatArray = (V * np.clip(lam, std_min_m**2, std_max_m**2)) @ V.T
    return 0.5 * (out + out.T)


def publish_step(
    previous: Published | None,
    center_enu_m: FloatArray,
    cov_enu_m2: FloatArray,
    cfg: RegionPublishConfig,
) -> Published:
    """The region published this cycle, given the one published last cycle (module docstring)."""
    cov = clamp_std(cov_enu_m2, cfg.std_min_m, cfg.std_max_m)
    if previous is None:
        return Published(np.array(center_enu_m, dtype=np.float64), cov)
    target = np.array(center_enu_m, dtype=np.float64)
    step = target - previous.center_enu_m
    step_m = float(np.linalg.norm(step))
    if cfg.max_center_step_m > 0.0 and step_m > cfg.max_center_step_m:
        target = previous.center_enu_m + step * (cfg.max_center_step_m / step_m)
    trace_previous = float(np.trace(previous.cov_enu_m2))
    trace_now = float(np.trace(cov))
    limit = cfg.max_trace_growth * trace_previous
    if cfg.max_trace_growth > 0.0 and trace_now > limit > 0.0:
        cov = clamp_std(cov * (limit / trace_now), cfg.std_min_m, cfg.std_max_m)
    a_c, a_s = cfg.center_ema_gain, cfg.cov_ema_gain
    center = (1.0 - a_c) * previous.center_enu_m + a_c * target
    smoothed = (1.0 - a_s) * previous.cov_enu_m2 + a_s * cov
    return Published(center, clamp_std(smoothed, cfg.std_min_m, cfg.std_max_m))


class RegionPublisher:
    """The last region published per uas_id, and the rule that makes the next one."""

    def __init__(self, cfg: RegionPublishConfig) -> None:
        self.cfg = cfg
        self._last: dict[str, Published] = {}

    def publish(
        self, uas_id: str, center_enu_m: FloatArray, cov_enu_m2: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """(centre, covariance) to publish for ``uas_id`` this cycle: the estimate itself
        when publishing is off."""
        if not self.cfg.enabled:
            return center_enu_m, cov_enu_m2
        out = publish_step(self._last.get(uas_id), center_enu_m, cov_enu_m2, self.cfg)
        self._last[uas_id] = out
        return out.center_enu_m, out.cov_enu_m2

    def forget(self, uas_id: str) -> None:
        """Drop ``uas_id``'s history (its track was deleted: a new track starts afresh)."""
        self._last.pop(uas_id, None)
