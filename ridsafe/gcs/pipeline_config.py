"""Configuration of the GCS estimation pipeline (detection -> localisation -> IMM -> region).

Frozen dataclasses loaded by :mod:`ridsafe.common.config`; each section validates itself in
``__post_init__`` and names the offending field (``transition[1]: sums to 0.97, must be 1``).

Where the paper (or the authors' code, REFERENCE.md) gives a value it is the default:
the IMM's dt, mu0, transition matrix, Q and R (paper appendix table, DESIGN.md section 6),
the per-pair NIS detector (Q 0.01, R 4, P0 10, threshold chi2_1 99 % = 6.63), the
multilateration (>= 4 receivers, unknowns x, y, z, Pt, TRF, Pt bounded to +/-50 dBm), the
CV -> CA lift variance (64 (m/s^2)^2), the 5 s forced alert, alpha = 0.05.

Where it gives none, ours, each documented at its field:

- ``rssi_sigma_db = 1.0``: the scenario's default shadowing (``radio.shadowing_sigma_db``).
  The pipeline assumes it; a run whose radio differs must set both (the detectors' false-alarm
  rate and the ellipsoids' honesty rest on it).
- ``estimator = 'rssi_imm'``: a Gaussian sum of IMMs (CV + CA) whose mode filters carry the
  transmit power as a state and update on the raw RSSI of every receiver by iterated posterior
  linearisation (``localisation/gaussian_sum.py``). Measured (``bench/bench_gcs.py --mc``,
  30 seeds, 1 dB, alert forced at 5 s, receivers airborne): containment at alpha = 0.05 of
  0.91 / 0.97 / 0.99 and RMSE 50 / 23 / 14 m with 4 / 8 / 16 receivers, against 0.70 / 0.88 /
  0.95 and 219 / 98 / 61 m for the paper's NLLS -> IMM with Jacobian fix covariances (0.51 /
  0.69 / 0.87, 362 / 140 / 70 m with the paper's fixed R). ``nlls_imm`` is the paper's
  pipeline, selectable.
- detection: tests across receivers and time with a false-alarm probability of 1e-6 per
  transmission and test, the multilateration check as an exact score test
  (``detection/rssi_consistency.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ridsafe.common.checks import (
    check_non_negative,
    check_positive,
)
from ridsafe.common.errors import FieldValueError
from ridsafe.common.messages import RidsafeDetector
from ridsafe.gcs.calibration.config import CalibrationConfig
from ridsafe.gcs.localisation.config import (
    AuthorsImmConfig,
    ImmConfig,
    MultilaterationConfig,
    RssiFilterConfig,
)
from ridsafe.gcs.localisation.registry import DEFAULT_ESTIMATOR, check_estimator

__all__ = [
    "DetectionConfig",
    "ForcedAlertConfig",
    "GroundTransmitterConfig",
    "PipelineConfig",
    "RegionConfig",
    "RegionPublishConfig",
    "TrackConfig",
]


@dataclass(frozen=True)
class DetectionConfig:
    """Spoofing detectors (``detection/``; which ones run: ``detection/registry.py``)."""

    #: First-metre loss the detectors use (the reference detectors' rounded 40.04 dB).
    loss_at_1m_db: float = 40.04
    #: Ours: std of the claimed and reported receiver positions (quantisation, telemetry lag),
    #: turned into dB at each distance: sigma_i^2 = sigma^2 + (20/ln10 * this / d_i)^2.
    #: Keeps close-range receptions from raising false alerts. The paper: 0.
    position_sigma_m: float = 2.0
    #: A transmission needs this many receivers to be tested.
    min_receivers: int = 3
    # --- the paper's detector: one scalar KF per (receiver, claimed transmitter) (REFERENCE.md)
    nis_q_db2: float = 0.01
    nis_r_db2: float = 4.0
    nis_p0_db2: float = 10.0
    nis_threshold: float = 6.63  # chi2_1 at 99 %
    # --- ours: tests across receivers and time
    #: Sliding window of the windowed tests (NIS_WINDOW, MLAT), seconds.
    window_s: float = 10.0
    #: > 0: MLAT_LONG, the MLAT test over this longer window (seconds, more than
    #: ``window_s``; the window holds at most the ring's 64 claims), its own detector with
    #: its own threshold and, calibrating, its own empirical null. A constant lie's evidence
    #: grows with the time it is heard, so on a channel whose errors are independent the long
    #: window detects a weak lie sooner; where errors repeat over time (urban) the cooperative
    #: aircraft's long-window statistics grow too, its null rises, and the short window keeps
    #: its speed. 0: off.
    long_window_s: float = 0.0
    #: > 0: MLAT_CENSORED (``detection/censored.py``), the likelihood-ratio test of a common
    #: offset over this window (seconds) with each reception taken from a normal truncated
    #: at its receiver's cut (nothing weaker is reported), where the calibration estimates
    #: the cut: a transmitter heard only near the cut (a short-range channel: exponent 3) is
    #: tested on what such receptions hold rather than on a lift subtracted from them. Run
    #: only on windows with a reception within ``censored_margin_sigma`` noise stds of its
    #: cut (elsewhere it is the MLAT test). Measured, not adopted: docs/results/
    #: robustness.md, "Who did not hear it". 0: off.
    censored_window_s: float = 0.0
    censored_margin_sigma: float = 3.0
    #: False-alarm probability per transmission of POWER_SPREAD, NIS_WINDOW, MLAT, MLAT_LONG
    #: and MLAT_CENSORED (each; with the long window on, the two MLAT tests together up to
    #: twice this, and more with the censored test); their
    #: statistics are reported as surprisal -log10(p-value), threshold -log10(this).
    p_false_alarm: float = 1e-6
    #: CUSUM on the probit of each transmission's MLAT p-value: g = max(0, g + z - drift).
    cusum_drift: float = 0.5
    cusum_threshold: float = 12.0  # ARL0 ~ 1e6 transmissions (Siegmund's approximation)
    #: Detectors whose decision raises an alert; the others are computed and reported only.
    alerting: tuple[RidsafeDetector, ...] = (
        RidsafeDetector.MLAT,
        RidsafeDetector.NIS_WINDOW,
        RidsafeDetector.CUSUM,
        RidsafeDetector.MLAT_LONG,  # reported only with long_window_s > 0
        RidsafeDetector.MLAT_CENSORED,  # reported only with censored_window_s > 0
    )

    def __post_init__(self) -> None:
        check_non_negative("loss_at_1m_db", self.loss_at_1m_db)
        check_non_negative("position_sigma_m", self.position_sigma_m)
        if self.min_receivers < 2:
            raise FieldValueError("min_receivers", f"expected >= 2, got {self.min_receivers}")
        for name in ("nis_q_db2", "nis_r_db2", "nis_p0_db2", "nis_threshold", "window_s"):
            check_positive(name, getattr(self, name))
        if not 0.0 < self.p_false_alarm < 0.5:
            raise FieldValueError(
                "p_false_alarm", f"expected 0 < p < 0.5, got {self.p_false_alarm}"
            )
        check_non_negative("cusum_drift", self.cusum_drift)
        if self.long_window_s != 0.0 and not self.long_window_s > self.window_s:
            raise FieldValueError(
                "long_window_s",
                f"expected 0 (off) or more than window_s={self.window_s:g}, "
                f"got {self.long_window_s:g}",
            )
        check_non_negative("censored_window_s", self.censored_window_s)
        check_positive("censored_margin_sigma", self.censored_margin_sigma)
        check_positive("cusum_threshold", self.cusum_threshold)
        for i, det in enumerate(self.alerting):
            if det is RidsafeDetector.FORCED:
                raise FieldValueError(f"alerting[{i}]", "FORCED is set in forced_alert")


@dataclass(frozen=True)
class TrackConfig:
    """Track initiation, coasting and deletion (``tracks.py``); initial uncertainties (ours)."""

    #: On alert the track starts from the transmitter's receptions of the last this many
    #: seconds (kept for the detectors anyway), not from the next transmission only.
    backfill_s: float = 10.0
    #: Delete the track (and clear the alert) when the transmitter is silent this long.
    silence_timeout_s: float = 10.0
    #: Coast an alerted track through its transmitter's silence while its region's largest
    #: semi-axis stays within this (m), past ``silence_timeout_s`` (a spoofer that stops
    #: transmitting keeps flying: its predicted region, growing with the prediction's
    #: covariance, stays for the planners); deleted once wider, or after 60 s of silence.
    #: 0: delete at ``silence_timeout_s`` (the paper's pipeline).
    coast_max_radius_m: float = 0.0
    #: RSSI_IMM: start the track only once the grid posterior's horizontal std is below this
    #: (m); 0 starts at once. Receivers clustered at depots can leave the spoofer anywhere
    #: along a curve; a region covering the whole area helps no planner.
    max_init_std_m: float = 150.0
    #: RSSI_IMM: the spans (s) of claims the grid posterior of a track start may take, tried
    #: shortest first at each newest claim; the first one tight enough starts the track
    #: (``initiation/grid.py``). More than one lets a channel whose errors repeat from claim to
    #: claim (three claims a second apart worth little more than one) wait for the geometry
    #: to change instead of for a lucky window; each at most the claims kept
    #: (``max(backfill_s, detection.window_s)``). (2.5,): the paper-era start.
    init_spans_s: tuple[float, ...] = (2.5,)
    #: RSSI_IMM: a claim heard by at least this many receivers may take part in a track
    #: start (the detectors need ``multilateration.min_receivers``, 4). One claim heard by
    #: three leaves the transmitter anywhere along a curve, but a window of them does not
    #: once the receivers have moved, and the grid posterior's spread (``max_init_std_m``)
    #: decides whether a window localises. With 4, an alerted spoofer heard by three
    #: aircraft had no region for up to a minute (path-loss exponent 3, 8 aircraft).
    init_min_receivers: int = 3
    #: Track a *stranger* before any alert: a transmitter heard in at least this many
    #: claims none of which any cooperative aircraft accounted for (the calibration's
    #: labeller never matched one to a receiver's own position, ``calibration/
    #: cooperative.py``). Its region, flagged UNCONFIRMED, is where its radio is, whatever
    #: it claims, so planners keep clear of a liar while the detectors still gather
    #: evidence; an honest stranger's region is where it is anyway. The alert stays the
    #: detectors' decision. 0: only alerted transmitters are tracked (the paper). Needs the
    #: labeller (``calibration.enabled`` true or auto).
    strangers_after_claims: int = 0
    #: A stranger's region is published only while its largest semi-axis is within this
    #: (m): wider, it holds back more traffic than it protects from a transmitter that may
    #: well be honest (its track runs on; an alert publishes it whatever its size).
    strangers_max_semi_axis_m: float = 250.0
    #: Receptions by receivers lower than this (m above the ground) are left out of the
    #: tracks (their start and updates); the detectors keep them. 0 keeps every reception.
    #: Aircraft on their pads hear a transmitter through the ground's reflection, and on a
    #: channel with one their RSSI says little of where it is.
    min_receiver_height_m: float = 0.0
    #: A single-hypothesis RSSI_IMM's altitude std: U(0, 120 m), the small-UAS legal band,
    #: moment-matched (120 / sqrt(12)).
    altitude_prior_std_m: float = 34.6
    init_speed_std_m_s: float = 6.0
    #: Level-flight prior (see ``RssiFilterConfig``).
    init_vertical_speed_std_m_s: float = 0.1
    init_accel_std_m_s2: float = 1.0
    init_vertical_accel_std_m_s2: float = 0.01

    def __post_init__(self) -> None:
        check_non_negative("backfill_s", self.backfill_s)
        check_non_negative("max_init_std_m", self.max_init_std_m)
        spans = self.init_spans_s
        if not spans or any(not 0.0 < s < math.inf for s in spans) or list(spans) != sorted(spans):
            raise FieldValueError(
                "init_spans_s", f"expected one or more spans > 0 s, ascending, got {list(spans)}"
            )
        check_non_negative("coast_max_radius_m", self.coast_max_radius_m)
        check_non_negative("min_receiver_height_m", self.min_receiver_height_m)
        check_non_negative("strangers_after_claims", self.strangers_after_claims)
        check_positive("strangers_max_semi_axis_m", self.strangers_max_semi_axis_m)
        if self.init_min_receivers < 3:
            raise FieldValueError(
                "init_min_receivers",
                f"expected >= 3 (fewer cannot tell a direction), got {self.init_min_receivers}",
            )
        for name in (
            "silence_timeout_s",
            "altitude_prior_std_m",
            "init_speed_std_m_s",
            "init_vertical_speed_std_m_s",
            "init_accel_std_m_s2",
            "init_vertical_accel_std_m_s2",
        ):
            check_positive(name, getattr(self, name))


@dataclass(frozen=True)
class RegionPublishConfig:
    """How an estimate becomes the published region (``region/publishing.py``). Off by
    default: the region is the estimate's own mean and covariance. ``enabled`` publishes as the
    authors' code did (docs/paper_mode.md): every covariance clamped to std
    [``std_min_m``, ``std_max_m``] along its eigenvectors; after the first, the centre moves at
    most ``max_center_step_m`` per cycle towards the estimate, the covariance trace grows at
    most by the factor ``max_trace_growth`` per cycle, then both are smoothed by exponential
    moving averages of gains ``center_ema_gain`` / ``cov_ema_gain`` (1 = no smoothing)."""

    enabled: bool = False
    std_min_m: float = 4.0
    std_max_m: float = 35.0
    center_ema_gain: float = 0.35
    cov_ema_gain: float = 0.25
    #: 0 disables the step limit; 0 disables the growth limit.
    max_center_step_m: float = 30.0
    max_trace_growth: float = 1.8

    def __post_init__(self) -> None:
        check_positive("std_min_m", self.std_min_m)
        if not self.std_max_m >= self.std_min_m:
            raise FieldValueError(
                "std_max_m", f"expected >= std_min_m ({self.std_min_m}), got {self.std_max_m}"
            )
        for name in ("center_ema_gain", "cov_ema_gain"):
            gain = getattr(self, name)
            if not 0.0 < gain <= 1.0:
                raise FieldValueError(name, f"expected 0 < gain <= 1, got {gain}")
        check_non_negative("max_center_step_m", self.max_center_step_m)
        if self.max_trace_growth != 0.0 and self.max_trace_growth < 1.0:
            raise FieldValueError(
                "max_trace_growth", f"expected 0 (off) or >= 1, got {self.max_trace_growth}"
            )


@dataclass(frozen=True)
class RegionConfig:
    """Chance-constrained unsafe region (paper eq. (10)-(11))."""

    alpha: float = 0.05
    #: A region may be used until this long after the estimate it comes from.
    validity_s: float = 1.0
    publish: RegionPublishConfig = field(default_factory=RegionPublishConfig)

    def __post_init__(self) -> None:
        if not 0.0 < self.alpha < 1.0:
            raise FieldValueError("alpha", f"expected 0 < alpha < 1, got {self.alpha}")
        check_positive("validity_s", self.validity_s)


@dataclass(frozen=True)
class GroundTransmitterConfig:
    """Ghosts (``region/ground.py``): an alerted transmitter whose track stands still while its
    claim flies is taken for a radio on the ground, and its region is published flat on the
    ground (from ``rssi_filter.ground_z_enu_m`` up to ``max_height_m``), flagged ON_GROUND.

    Still: over the last ``window_s`` the track's horizontal estimates all lie within
    ``still_radius_m`` of their mean (``keep_radius_m`` once recognised) and the mean of its
    velocity estimates is below twice that radius over the window, while its claimed
    position moved at least ``min_claim_travel_m``; and low: the ground layer within
    ``height_sigmas`` standard deviations of its estimated height. Off by default (every
    region as estimated); it needs the ground (``rssi_filter.ground_z_enu_m``)."""

    enabled: bool = False
    window_s: float = 15.0
    still_radius_m: float = 20.0
    keep_radius_m: float = 30.0
    min_claim_travel_m: float = 45.0
    #: The published region spans the ground to this height (m): a radio held, on a roof
    #: or on a mast.
    max_height_m: float = 10.0
    #: Only while that layer lies within this many standard deviations of the estimate's
    #: height (a transmitter known to be high is not on the ground).
    height_sigmas: float = 2.0

    def __post_init__(self) -> None:
        names = ("window_s", "still_radius_m", "min_claim_travel_m", "max_height_m")
        for name in (*names, "height_sigmas"):
            check_positive(name, getattr(self, name))
        if not self.keep_radius_m >= self.still_radius_m:
            raise FieldValueError(
                "keep_radius_m",
                f"expected >= still_radius_m ({self.still_radius_m}), got {self.keep_radius_m}",
            )


@dataclass(frozen=True)
class ForcedAlertConfig:
    """The paper's experiments force the alert for the spoofer's serial at 5 s."""

    enabled: bool = False
    uas_id: str = ""
    time_s: float = 5.0
    #: With a forced alert, may the real detectors still raise alerts (on any uas_id)?
    detectors_also_alert: bool = False

    def __post_init__(self) -> None:
        if self.enabled and not self.uas_id:
            raise FieldValueError("uas_id", "a forced alert needs the uas_id to alert on")
        check_non_negative("time_s", self.time_s)


@dataclass(frozen=True)
class PipelineConfig:
    """Everything the estimation pipeline needs (nested sections above)."""

    #: RSSI noise the pipeline assumes (dB), matching the scenario's default shadowing; with
    #: ``calibration.enabled: auto`` (the default) only while the cooperative aircraft's
    #: receptions agree.
    rssi_sigma_db: float = 1.0
    #: The localisers' RSSI variance is ``rssi_sigma_db^2`` times this (the detectors' is
    #: not inflated): the error the channel model leaves that repeats over time and links,
    #: which the calibration measures on the cooperative aircraft (``calibration/``).
    localisation_noise_inflation: float = 1.0
    #: Which estimator a track runs, by its name in ``localisation/registry.py``: 'rssi_imm'
    #: (ours) or 'nlls_imm' (the paper's NLLS fix -> IMM), or one you registered there.
    estimator: str = DEFAULT_ESTIMATOR
    detection: DetectionConfig = field(default_factory=DetectionConfig)
    multilateration: MultilaterationConfig = field(default_factory=MultilaterationConfig)
    imm: ImmConfig = field(default_factory=ImmConfig)
    rssi_filter: RssiFilterConfig = field(default_factory=RssiFilterConfig)
    authors_imm: AuthorsImmConfig = field(default_factory=AuthorsImmConfig)
    tracks: TrackConfig = field(default_factory=TrackConfig)
    region: RegionConfig = field(default_factory=RegionConfig)
    forced_alert: ForcedAlertConfig = field(default_factory=ForcedAlertConfig)
    #: Ghosts: a still transmitter whose claim flies, published on the ground.
    ghosts: GroundTransmitterConfig = field(default_factory=GroundTransmitterConfig)
    #: Channel calibration on the cooperative aircraft (``calibration/``); ``auto``: the
    #: channel is ``rssi_sigma_db`` and free space, as configured, while the receptions fit
    #: it; off: whatever they say.
    calibration: CalibrationConfig = field(default_factory=CalibrationConfig)
    #: Work bound per cycle: at most this many claims run in one cycle (0: all), or the
    #: least even number per cycle that runs every waiting claim within
    #: ``max_claim_wait_s`` if that is more; the rest wait for the next cycles, oldest
    #: first; suspects' claims (alerted, new, or near an alerting threshold:
    #: ``pipeline.SUSPICION``) never wait, none longer than ``max_claim_wait_s``. Aircraft
    #: broadcasting in phase bring all their claims to one cycle in four: 64 aircraft's claims
    #: then run as 22, 21, 21 around the tracked spoofer's cycle (``pipeline.py``, step 0), a
    #: second's claims over a second's cycles. Up to 16 aircraft and a spoofer (the paper's
    #: fleets) nothing waits.
    max_claims_per_cycle: int = 17
    max_claim_wait_s: float = 0.75
    #: In that bound, a claim that updates a track counts as this many: the track's
    #: Gaussian-sum update over every receiver costs about as much as detection on 30
    #: claims (64 aircraft: ~0.7 ms against ~20 us per claim, the claims of a real run
    #: replayed), so the cycle of a spoofer's claim takes fewer of the waiting ones. It
    #: changes nothing while every claim fits in a cycle.
    track_claim_cost: int = 30

    @property
    def claims_kept_s(self) -> float:
        """How long each transmitter's claims are kept (s): for detection's window and the
        track start's backfill alike."""
        return max(self.tracks.backfill_s, self.detection.window_s)

    @property
    def localisation_sigma_db(self) -> float:
        """The RSSI noise std the localisers assume: ``rssi_sigma_db`` inflated."""
        if self.localisation_noise_inflation == 1.0:
            return self.rssi_sigma_db
        return self.rssi_sigma_db * math.sqrt(self.localisation_noise_inflation)

    def __post_init__(self) -> None:
        check_positive("rssi_sigma_db", self.rssi_sigma_db)
        if self.localisation_noise_inflation < 1.0:
            raise FieldValueError(
                "localisation_noise_inflation",
                f"expected >= 1, got {self.localisation_noise_inflation}",
            )
        check_estimator(self.estimator)
        if self.max_claims_per_cycle < 0:
            raise FieldValueError(
                "max_claims_per_cycle", f"expected >= 0, got {self.max_claims_per_cycle}"
            )
        if self.track_claim_cost < 1:
            raise FieldValueError("track_claim_cost", f"expected >= 1, got {self.track_claim_cost}")
        check_positive("max_claim_wait_s", self.max_claim_wait_s)
        kept_s = self.claims_kept_s
        if self.tracks.init_spans_s[-1] > kept_s:
            raise FieldValueError(
                "tracks.init_spans_s",
                f"the longest span {self.tracks.init_spans_s[-1]:g} s is more than the claims "
                f"kept: max(tracks.backfill_s, detection.window_s) = {kept_s:g} s",
            )
        if self.tracks.strangers_after_claims and self.calibration.enabled is False:
            raise FieldValueError(
                "tracks.strangers_after_claims",
                "telling a stranger needs the cooperative aircraft's labeller: "
                "calibration.enabled true or auto",
            )
        if self.ghosts.enabled and self.rssi_filter.ground_z_enu_m is None:
            raise FieldValueError(
                "ghosts.enabled", "a transmitter on the ground needs rssi_filter.ground_z_enu_m"
            )
