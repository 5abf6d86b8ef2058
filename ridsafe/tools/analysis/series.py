"""Run metrics over time, for plots (the paper's Fig. 3): :func:`metric_series`.

The same quantities as :mod:`ridsafe.tools.analysis.metrics`, sample by sample instead of
summarised: distance to the spoofer per truth sample, containment per region, localisation
error per track record, arrival time per aircraft.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ridsafe.tools.analysis.metrics import (
    DEFAULT_MIN_HEIGHT_M,
    alert_time_s,
    arrival_times_s,
    containment_samples,
    distance_to_spoofer_m,
    localisation_errors,
)
from ridsafe.tools.analysis.run_arrays import RunLog, load_run

__all__ = ["MetricSeries", "metric_series"]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True, eq=False)
class MetricSeries:
    """Metrics over time, for plots.

    - ``t_s`` (T,), ``min_distance_to_spoofer_m`` (T,): truth samples; NaN where no benign
      aircraft is airborne or there is no spoofer.
    - ``region_t_s`` (K,), ``contained`` (K,), ``containment_rate`` (K,): each spoofer region
      at/after the alert, whether it contained the truth, and the running fraction so far.
    - ``track_t_s`` (M,), ``localisation_error_m`` (M,): 3D error of each spoofer track record
      at/after the alert.
    - ``arrival_time_s``: benign sysid -> first time within the arrival radius, or None.
    """

    t_s: FloatArray
    min_distance_to_spoofer_m: FloatArray
    region_t_s: FloatArray
    contained: BoolArray
    containment_rate: FloatArray
    track_t_s: FloatArray
    localisation_error_m: FloatArray
    alert_time_s: float | None
    nmac_threshold_m: float
    arrival_time_s: Mapping[int, float | None]


def metric_series(
    source: str | os.PathLike[str] | RunLog, *, min_height_m: float = DEFAULT_MIN_HEIGHT_M
) -> MetricSeries:
    run = source if isinstance(source, RunLog) else load_run(source)
    region_t, contained = containment_samples(run)
    running = np.cumsum(contained) / np.arange(1, contained.size + 1)
    track_t, errors = localisation_errors(run)
    return MetricSeries(
        t_s=run.truth.t_s,
        min_distance_to_spoofer_m=distance_to_spoofer_m(run, min_height_m),
        region_t_s=region_t,
        contained=contained,
        containment_rate=running.astype(np.float64),
        track_t_s=track_t,
        localisation_error_m=errors,
        alert_time_s=alert_time_s(run),
        nmac_threshold_m=run.nmac_threshold_m,
        arrival_time_s=arrival_times_s(run),
    )
