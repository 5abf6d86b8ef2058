"""The interface between the GCS shell (ingest, cycle, messaging) and its estimation pipeline.

The shell validates observation reports, converts them into the scenario ENU frame about
the configured origin, groups them by broadcast (claimed id + RID timestamp) into
``ObservedClaim``s and, every GCS cycle (0.25 s), hands the pipeline the claims that closed
since the last cycle. The pipeline (detection -> initiation -> localisation -> tracking ->
unsafe region) answers with what it decided; the shell logs it and sends alerts and regions
to every companion.

An ``ObservedClaim`` is not a radio transmission (that is the sim's
``sim_backend.radio.Transmission``, the bytes on the air): it is what the GCS learns of one:
what the broadcast claims, and who reported hearing it, where, when and how loud.

Frames and units: positions ``*_enu_m`` in the scenario ENU frame, covariances in m^2 in
the same axes, times in sim seconds, powers in dBm.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import accumulate
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.frozen import quick_init
from ridsafe.common.messages import AlertState, RidsafeDetector

FloatArray = NDArray[np.float64]

#: What the GCS remembers of a claimed transmitter (detector memory, labels, counts) is
#: dropped after this much silence (seconds): a stream of new serials must not grow it.
FORGET_AFTER_S = 60.0


def readonly(values: object) -> FloatArray:
    """A float64 copy that cannot be written (for arrays stored in frozen dataclasses)."""
    arr = np.array(values, dtype=np.float64)
    arr.setflags(write=False)
    return arr


@quick_init
@dataclass(frozen=True, eq=False)
class ObservedClaim:
    """One RID broadcast's claim (who, where, how fast) with every reception of it that the
    companions reported.

    ``rx_sysid : (k,) int``, ``rx_p_enu_m : (k, 3)``, ``rx_t_s : (k,)``, ``rssi_dbm : (k,)``:
    receiver ids, their own positions and times at reception, and the RSSI each measured.
    """

    uas_id: str
    rid_timestamp_s: float
    claimed_p_enu_m: FloatArray  # (3,)
    claimed_v_enu_m_s: FloatArray | None  # (3,) or None when the broadcast had no speed
    rx_sysid: NDArray[np.int64]
    rx_p_enu_m: FloatArray
    rx_t_s: FloatArray
    rssi_dbm: FloatArray
    #: The RSSI the tracks use where it differs from what the detectors test (None: the
    #: same). The calibration's antenna gain by elevation is taken at the claimed position:
    #: right for testing the claim, wrong for locating a transmitter that lies about it.
    track_rssi_dbm: FloatArray | None = None
    #: Where the receivers' sensitivity is estimated (``calibration/censoring.py``), the
    #: receptions as a censored sample for MLAT_CENSORED (``detection/censored.py``): the
    #: RSSI mapped as ``rssi_dbm`` is but without the lift above the cut subtracted, and
    #: each receiver's cut on the same scale (None: no cut known).
    cut_rssi_dbm: FloatArray | None = None
    cut_floor_dbm: FloatArray | None = None

    @functools.cached_property
    def t_s(self) -> float:
        """When the broadcast was heard (earliest reception; computed once, the arrays are
        read-only)."""
        return float(self.rx_t_s.min())

    @property
    def n_receivers(self) -> int:
        return int(self.rx_sysid.shape[0])


def reception_bounds(claims: Sequence[ObservedClaim]) -> NDArray[np.int64]:
    """Where each claim's receptions lie once the claims' are stacked in order: claim j's
    are rows ``bounds[j]:bounds[j + 1]`` of ``(len(claims) + 1,)`` bounds."""
    counts = (claim.rx_sysid.shape[0] for claim in claims)
    return np.fromiter(accumulate(counts, initial=0), dtype=np.int64, count=len(claims) + 1)


def claimed_positions(claims: Sequence[ObservedClaim]) -> FloatArray:
    """``(len(claims), 3)``: each claim's claimed position, in order (float64, C order;
    ``np.stack`` builds the same array at three times the cost, a GCS cycle stacks them
    for every claim it closes)."""
    if not claims:
        return np.zeros((0, 3))
    out: FloatArray = np.concatenate([claim.claimed_p_enu_m for claim in claims]).reshape(-1, 3)
    return out.astype(np.float64, copy=False)


def receptions(claim: ObservedClaim, keep: NDArray[np.bool_]) -> ObservedClaim:
    """The claim with only the receptions ``keep``."""
    return dataclasses.replace(
        claim,
        rx_sysid=claim.rx_sysid[keep],
        rx_p_enu_m=readonly(claim.rx_p_enu_m[keep]),
        rx_t_s=readonly(claim.rx_t_s[keep]),
        rssi_dbm=readonly(claim.rssi_dbm[keep]),
        track_rssi_dbm=None
        if claim.track_rssi_dbm is None
        else readonly(claim.track_rssi_dbm[keep]),
    )


def for_tracks(claim: ObservedClaim) -> ObservedClaim:
    """The claim as the tracks see it (``track_rssi_dbm`` when set)."""
    if claim.track_rssi_dbm is None:
        return claim
    return dataclasses.replace(claim, rssi_dbm=claim.track_rssi_dbm, track_rssi_dbm=None)


def airborne_receptions(claim: ObservedClaim, min_height_m: float) -> ObservedClaim:
    """The claim with only the receptions of receivers at least ``min_height_m`` above the
    ground (ENU up; flat ground at the origin's height). 0 keeps every reception."""
    if min_height_m <= 0.0:
        return claim
    keep = claim.rx_p_enu_m[:, 2] >= min_height_m
    return claim if bool(keep.all()) else receptions(claim, keep)


@quick_init
@dataclass(frozen=True)
class DetectorResult:
    """One detector's verdict on one observed claim (for logs and ROC curves)."""

    uas_id: str
    detector: RidsafeDetector
    statistic: float
    threshold: float
    decision: bool


@dataclass(frozen=True)
class AlertChange:
    uas_id: str
    detector: RidsafeDetector
    statistic: float
    threshold: float
    state: AlertState


@dataclass(frozen=True, eq=False)
class TrackEstimate:
    uas_id: str
    track_id: int
    p_enu_m: FloatArray  # (3,)
    cov_enu_m2: FloatArray  # (3, 3)
    v_enu_m_s: FloatArray  # (3,)
    mode_probabilities: FloatArray  # (2,) CV, CA
    fix: bool  # updated by a fix this cycle
    last_fix_s: float


@dataclass(frozen=True, eq=False)
class UnsafeRegion:
    """(x - c)^T P^-1 (x - c) <= chi2_threshold, with ``axes_enu`` columns the unit
    semi-axis directions for ``semi_axes_m`` (largest first)."""

    uas_id: str
    track_id: int
    t_s: float
    center_enu_m: FloatArray  # (3,)
    cov_enu_m2: FloatArray  # (3, 3)
    v_enu_m_s: FloatArray  # (3,)
    chi2_threshold: float
    alpha: float
    valid_until_s: float
    semi_axes_m: FloatArray  # (3,)
    axes_enu: FloatArray  # (3, 3)
    #: A radio standing on the ground (``region/ground.py``): the region is flat on it.
    on_ground: bool = False
    #: No alert stands: the transmitter is tracked as a stranger (``pipeline.py``).
    unconfirmed: bool = False


@dataclass(frozen=True)
class ChannelDecision:
    """Which channel the GCS now runs on, and why (``calibration/pipeline.py``): the
    ``configured`` one, kept while the cooperative receptions fit it, or one ``fitted`` to
    them. ``residual_std_db`` and ``p_value``: the test of the configured channel (None when
    none was made); ``exponent`` and ``sigma_db``: the fit (None on the configured one)."""

    channel: str  # 'configured', 'provisional' (calibration.provisional_*) or 'fitted'
    n_samples: int
    residual_std_db: float | None
    p_value: float | None
    exponent: float | None
    sigma_db: float | None


@dataclass(frozen=True)
class CycleOutput:
    #: every detector's result on each claim the cycle ran, a tuple per claim in their order
    claim_results: tuple[tuple[DetectorResult, ...], ...] = ()
    alert_changes: tuple[AlertChange, ...] = ()
    tracks: tuple[TrackEstimate, ...] = ()
    regions: tuple[UnsafeRegion, ...] = ()
    deleted_tracks: tuple[str, ...] = ()  # uas_ids whose track was deleted this cycle
    channel: ChannelDecision | None = None  # the GCS changed (or fitted again) its channel

    @property
    def detector_results(self) -> tuple[DetectorResult, ...]:
        """Every result of the cycle, claim after claim."""
        return tuple(r for results in self.claim_results for r in results)


class GcsPipeline(Protocol):
    def step(self, now_s: float, claims: Sequence[ObservedClaim]) -> CycleOutput: ...
