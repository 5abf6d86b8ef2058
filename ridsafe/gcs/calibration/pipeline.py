r"""A GCS pipeline that is not told the channel: it calibrates on its cooperative aircraft.

``CalibratingPipeline`` wraps the estimation pipeline (``gcs/pipeline.py``). Until it has
enough labelled receptions (``cooperative.py``) for the parameters the fit has
(``samples_per_parameter`` each, at least ``min_samples``) and ``min_time_s`` has passed it
holds the claims (the last ``hold_s`` seconds); then it fits the channel
(``channel_fit.py``, again every ``refit_s``: the first fit sees the aircraft on the ground
at their depots, a different channel from the airborne one) and hands the inner pipeline
every claim, held ones first, with the RSSI mapped onto the free-space model the detectors
and localisers assume::

    rssi' = (2 / n) (rssi - b_r)

With rssi = P_s + b_r - 10 n log10 d + e this is rssi' = P'_s - 20 log10 d + (2/n) e, the
paper's model with a transmit power P'_s the estimators fit anyway, and noise std (2/n)
sigma. The scaling is taken about the fleet's mean level P0 of the first fit (rssi' = P0 +
(2/n)(rssi - b_r - P0)), so a refit that moves n barely moves the P'_s a track has converged
on (scaled about 0, a refit from n = 2.9 to 3.0 moves a P of -20 dBm by 0.5 dB, which a
track, its power a slow random walk, takes for a range error). Even so a track does not
survive a changed mapping well (exponent 3, 2 dB, seed 0: containment 0.95 -> 0.65 with
refits during the track), so while any track runs the tracks' RSSI keeps the mapping in
force when the first of them started (``tracks_estimate``); the detectors' follows every
refit (a stranger's track, ``tracks.strangers_after_claims``, runs from the first seconds,
and the first fit, made on the ground, would otherwise test every claim after it: 8
aircraft at 6 dB, 10 seeds, mean detection delay 51 s so, 38 s with the refits). The noise
std is the inner
pipeline's ``rssi_sigma_db`` (floored at ``sigma_floor_db``). So the detectors' thresholds
and the localisers' measurement noise follow the fitted channel; ``pipeline.rssi_sigma_db``
is only the starting point that is never used once calibrated. What the fitted model still
gets wrong (heavy tails, errors repeated over time and links) the alert review measures on
the cooperative aircraft (``review.py``): the alert thresholds and the localisers' noise
follow it. The first alert can come no earlier than the calibration (a detection delay
measured in the report).

``calibration.enabled: auto`` (the default) asks first whether the channel is the
configured one (``channel_fit.check_configured_channel``: the labelled receptions'
chi-square under free space with ``rssi_sigma_db``) from ``configured_min_samples`` on.
While it is, the inner pipeline runs on the configured channel and the RSSI as received,
exactly as with calibration off, but for the cooperative cross-check and the first alert's
floor at the check; the check is repeated every ``refit_s`` until an alert is raised, and
the first that rejects the configured channel fits the channel and replays the held claims
into a pipeline on the fit, from then on as ``enabled: true``.

**A provisional fit** (``calibration.provisional_samples_per_parameter``, 0 by default)
starts the inner pipeline on a fit from fewer receptions, so that strangers' regions and
first alerts need not wait for the full warm-up. At the full warm-up a pipeline on the full
fit replaces it, the held claims replayed (``EstimationPipeline.take_over``: the alerts
raised meanwhile stand, their tracks start afresh on the full fit's mapping). A provisional
pipeline that kept running once it had alerted held its tracks to the young fit's mapping
(exponent 3, 8 aircraft: containment 0.871 -> 0.782); replaced, 0.860
(docs/results/robustness.md). Started afresh, a track of a transmitter crossing the fleet
begins where the oldest held claims put it and may trail it (exponent 3, 8 aircraft, seed 6:
57 m off after the switch where the running track was 33 m off). With
``calibration.provisional_keeps_tracks`` the running tracks go on instead, moved onto the
full fit's mapping (``_remap_tracks``): the mapping is linear in the RSSI about the pivot,
so at a track's receivers it moves the measurements by about the same amount, which its
transmit power takes; the pivot stays the provisional fit's.

**Antennas are not isotropic** (``calibration.elevation_knots_deg``): a dipole on an
airframe loses several dB toward steep links, a loss the plain fit can only count as noise,
so its sigma grows and the detectors lose their power (vertical dipoles, 16 aircraft: 6 runs
in 10 never alerted). A second fit gives the links a gain by elevation too
(``channel_fit.py``), and the detectors test each claim on its RSSI less that gain at the
*claimed* position, with that fit's (smaller) sigma: a claim is tested against what its own
position predicts. The tracks cannot do the same (a liar's claimed elevation is not its
elevation) and keep the plain fit's mapping (``ObservedClaim.track_rssi_dbm``) and sigma;
their honest inflation must be measured on that RSSI, so the detectors run once more on it
(``_TrackNoise``), their results used for nothing else.

**Receivers report nothing below their sensitivity** (``calibration.sensitivity_lift``): on
links near it only the receptions the noise lifted are reported. The fit is made on the RSSI
less each link's expected lift, and the detectors test each claim on its RSSI less the lift
its links would have were the claim true, with the sensitivity taken as the weakest RSSI
reported (``censoring.py``). The tracks keep the RSSI as received.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections import deque
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ridsafe.gcs.calibration.censoring import SensitivityFloor, lift_at_claims
from ridsafe.gcs.calibration.channel_fit import (
    ChannelEstimate,
    ConfiguredChannelCheck,
    check_configured_channel,
    fit_channel,
)
from ridsafe.gcs.calibration.config import CalibrationConfig
from ridsafe.gcs.calibration.cooperative import CooperativeLabeller, claim_links
from ridsafe.gcs.calibration.review import CalibratedReview
from ridsafe.gcs.detection.monitor import TransmitterMonitor, observe_batch
from ridsafe.gcs.localisation.gaussian_sum import GaussianSumLocaliser
from ridsafe.gcs.pipeline import EstimationPipeline
from ridsafe.gcs.pipeline_api import (
    FORGET_AFTER_S,
    ChannelDecision,
    CycleOutput,
    GcsPipeline,
    ObservedClaim,
    airborne_receptions,
    for_tracks,
    readonly,
    reception_bounds,
)
from ridsafe.gcs.pipeline_config import PipelineConfig

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]

__all__ = ["CalibratingPipeline", "make_pipeline", "to_free_space", "to_free_space_all"]


def to_free_space(
    claim: ObservedClaim, estimate: ChannelEstimate, pivot_dbm: float = 0.0
) -> ObservedClaim:
    """The claim with its RSSI mapped onto the free-space model (module docstring), scaled
    about ``pivot_dbm``: rssi' = pivot + (2 / n) (rssi - b_r - pivot)."""
    return to_free_space_all([claim], estimate, pivot_dbm)[0]


def to_free_space_all(
    claims: Sequence[ObservedClaim],
    estimate: ChannelEstimate,
    pivot_dbm: float = 0.0,
    tested: ChannelEstimate | None = None,
    floor_dbm: float = -math.inf,
    tracks: ChannelEstimate | None = None,
    censored_sample: bool = False,
) -> list[ObservedClaim]:
    """``to_free_space`` of each claim, the cycle's receptions mapped in one pass. With
    ``tested`` (the detectors' fit: with the links' gain by elevation, or on the RSSI less
    the sensitivity's lift) the detectors get the RSSI mapped by it, the gain taken at the
    claimed position (a test of the claim), and the tracks (``track_rssi_dbm``) the RSSI
    mapped by ``estimate`` (they cannot know a liar's elevation). With a finite
    ``floor_dbm`` (the receivers' sensitivity, as estimated) the detectors' RSSI is less each
    link's expected lift above its mean at the claimed position (``censoring.py``), and with
    ``censored_sample`` the claims carry their receptions as a censored sample as well
    (``ObservedClaim.cut_rssi_dbm``, ``cut_floor_dbm``: MLAT_CENSORED's input); the tracks'
    RSSI is not lifted. With ``tracks`` (a fit the running tracks hold to) the tracks get
    the RSSI mapped by it, the detectors by ``estimate`` (or ``tested``)."""
    if not claims:
        return []
    bounds_array = reception_bounds(claims)
    bounds = bounds_array.tolist()
    rssi_dbm = np.concatenate([claim.rssi_dbm for claim in claims])
    rx_sysid = np.concatenate([claim.rx_sysid for claim in claims])
    mapped = _mapped(rssi_dbm - estimate.bias_of(rx_sysid), estimate, pivot_dbm)
    own_tracks = tracks is not None and tracks is not estimate
    for_tracks_dbm = mapped
    if tracks is not None and own_tracks:
        for_tracks_dbm = _mapped(rssi_dbm - tracks.bias_of(rx_sysid), tracks, pivot_dbm)
    if tested is None and not math.isfinite(floor_dbm):
        return [
            dataclasses.replace(
                claim,
                rssi_dbm=mapped[bounds[j] : bounds[j + 1]],
                track_rssi_dbm=(
                    for_tracks_dbm[bounds[j] : bounds[j + 1]]
                    if own_tracks
                    else claim.track_rssi_dbm
                ),
            )
            for j, claim in enumerate(claims)
        ]
    tested = estimate if tested is None else tested
    distance_m, elevation_deg = claim_links(claims)
    gain_db = tested.elevation_gain_of(elevation_deg)
    bias_db = tested.bias_of(rx_sysid)
    corrected = rssi_dbm - bias_db - gain_db
    cut: tuple[FloatArray, FloatArray] | None = None  # (RSSI, cut) as a censored sample
    if math.isfinite(floor_dbm) and censored_sample:
        cut = (
            _mapped(corrected, tested, pivot_dbm),
            _mapped(floor_dbm - bias_db - gain_db, tested, pivot_dbm),
        )
    if math.isfinite(floor_dbm):
        loss_db = 10.0 * tested.exponent * np.log10(np.maximum(distance_m, 1.0)) - gain_db
        corrected = corrected - lift_at_claims(
            rssi_dbm, bounds_array, loss_db, bias_db, floor_dbm, tested.sigma_db
        )
    for_test = _mapped(corrected, tested, pivot_dbm)
    return [
        dataclasses.replace(
            claim,
            rssi_dbm=for_test[bounds[j] : bounds[j + 1]],
            track_rssi_dbm=for_tracks_dbm[bounds[j] : bounds[j + 1]],
            cut_rssi_dbm=None if cut is None else cut[0][bounds[j] : bounds[j + 1]],
            cut_floor_dbm=None if cut is None else cut[1][bounds[j] : bounds[j + 1]],
        )
        for j, claim in enumerate(claims)
    ]


def _mapped(corrected_dbm: FloatArray, estimate: ChannelEstimate, pivot_dbm: float) -> FloatArray:
    """RSSI already less the receivers' biases (and whatever else the caller corrects),
    scaled about ``pivot_dbm`` (module docstring)."""
    return readonly(pivot_dbm + (2.0 / estimate.exponent) * (corrected_dbm - pivot_dbm))


class CalibratingPipeline:
    """The ``GcsPipeline`` protocol: calibrate, then the estimation pipeline on mapped RSSI
    (``calibration.enabled: true``), or on the RSSI as received while the configured channel
    fits the cooperative receptions (``auto``; ``estimate`` is None while it does)."""

    def __init__(self, config: PipelineConfig) -> None:
        EstimationPipeline.ensure_warm()  # the inner pipeline comes mid-run
        CooperativeLabeller.ensure_warm()
        self.config = config
        self.labeller = CooperativeLabeller(config.calibration)
        #: The fitted pipeline's review (its empirical null), made with each fit's pipeline.
        self.review: CalibratedReview | None = None
        self.estimate: ChannelEstimate | None = None
        #: The fit the detectors' claims are mapped with, with the links' gain by elevation
        #: and on the RSSI less the sensitivity's lift (module docstring); None: the plain
        #: fit ``estimate``, which the tracks' claims are mapped with, is the same.
        self.tested_estimate: ChannelEstimate | None = None
        self.inner: EstimationPipeline | None = None
        #: The fit the running tracks' RSSI is mapped with: the one in force when the first
        #: of them started, kept while any runs (None: ``estimate``; module docstring).
        self.tracks_estimate: ChannelEstimate | None = None
        self._held: deque[ObservedClaim] = deque()
        self._newest_held_s = 0.0
        self._checked_s = 0.0  # when the channel was last fitted or checked
        self._pivot_dbm = 0.0  # the first fit's mean transmitter level (module docstring)
        self._configured_rejected = False
        self._rejection: ConfiguredChannelCheck | None = None  # the check that rejected it
        self._decision: ChannelDecision | None = None  # for this cycle's output
        self._track_noise: _TrackNoise | None = None  # with a detectors' fit of its own
        self._floor = SensitivityFloor()  # the weakest RSSI reported (censoring.py)
        #: On a provisional fit (``provisional_samples_per_parameter``) until the full one.
        self.provisional = False

    @property
    def on_configured_channel(self) -> bool:
        """``auto``, and the configured channel still fits the cooperative receptions."""
        return self.inner is not None and self.estimate is None

    def step(self, now_s: float, claims: Sequence[ObservedClaim]) -> CycleOutput:
        self._hold_tracks_mapping()
        self.labeller.observe_all(claims)
        self._floor.observe(claims)
        chosen = self._choose_channel(now_s, claims)
        if chosen is None:
            return CycleOutput()  # warming up
        claims, replaced = chosen
        assert self.inner is not None
        h = self.config.calibration.min_receiver_height_m
        claims = [airborne_receptions(c, h) for c in claims]
        if self.estimate is not None:
            claims = to_free_space_all(
                claims,
                self.estimate,
                self._pivot_dbm,
                self.tested_estimate,
                self._floor_dbm(),
                self.tracks_estimate,
                censored_sample=self.config.detection.censored_window_s > 0.0,
            )
            if self._track_noise is not None:
                self._track_noise.observe(claims)
        out = self.inner.step(now_s, claims)
        if replaced is not None:  # the tracks the new pipeline did not start again end
            ended = tuple(u for u in replaced.tracks if u not in self.inner.tracks)
            out = dataclasses.replace(out, deleted_tracks=out.deleted_tracks + ended)
        self._update_inflation(now_s)
        if self._decision is not None:
            out, self._decision = dataclasses.replace(out, channel=self._decision), None
        return out

    def _choose_channel(
        self, now_s: float, claims: Sequence[ObservedClaim]
    ) -> tuple[Sequence[ObservedClaim], EstimationPipeline | None] | None:
        """Start, keep or change the channel the inner pipeline runs on: the claims it is to
        step on (held ones replayed after a change) and the pipeline a new one replaced;
        None while warming up."""
        replaced: EstimationPipeline | None = None  # by a pipeline on the full fit
        if self.inner is None:
            self._hold(claims)
            if not self._start(now_s):
                return None
            claims = list(self._held)
            if not self.provisional:
                self._held = deque()
        elif self.provisional:
            self._hold(claims)  # replayed into the pipeline on the full fit
            if self._ready(now_s):
                replaced, self.provisional = self.inner, False
                keep = self.config.calibration.provisional_keeps_tracks and _remappable(replaced)
                mapping, pivot_dbm = self.tracks_estimate, self._pivot_dbm
                self._start_fitted(now_s)
                if keep:
                    self._pivot_dbm = pivot_dbm
                    self._remap_tracks(replaced, mapping)
                self.inner.take_over(replaced, keep_tracks=keep)
                claims, self._held = list(self._held), deque()
        elif self.on_configured_channel and self._may_switch():
            self._hold(claims)  # replayed should a later check reject the configured channel
            check = self._check_configured(now_s) if self._check_due(now_s) else None
            if check is not None and not check.fits:
                self._reject_configured(now_s, check)
                self._start_fitted(now_s)
                claims, self._held = list(self._held), deque()
        elif self.on_configured_channel and self.labeller.learning:
            self._held.clear()  # an alert is raised: the configured channel stays
            self.labeller.learning = False
        elif self._refit_due(now_s):
            self.estimate, self._checked_s = self._fit(None), now_s
        return claims, replaced

    def _start(self, now_s: float) -> bool:
        """Start the inner pipeline once the labelled receptions allow: on the configured
        channel if ``auto`` and it fits them (``CalibrationConfig.configured_accept_p``),
        else on the fit (its full warm-up)."""
        cal = self.config.calibration
        if cal.enabled == "auto" and not self._configured_rejected:
            if now_s < cal.min_time_s or len(self.labeller.samples) < cal.configured_min_samples:
                return False
            check = self._check_configured(now_s)
            if check.fits and (check.p_value >= cal.configured_accept_p or self._ready(now_s)):
                logger.info("t=%.2f s: the configured channel fits: %s", now_s, check.describe())
                review = CalibratedReview(self._veto_only(), self.labeller)
                self.inner = EstimationPipeline(self.config, review, self._strangers)
                n_samples = len(self.labeller.samples)
                self._decision = ChannelDecision(
                    "configured", n_samples, check.residual_std_db, check.p_value, None, None
                )
                return True
            if check.fits:
                return False  # not sure yet: more receptions
            self._reject_configured(now_s, check)
        if not self._ready(now_s):
            if not self._ready(now_s, provisional=True):
                return False
            self.provisional = True
        self._start_fitted(now_s)
        return True

    def _start_fitted(self, now_s: float) -> None:
        """A new inner pipeline on a fit made now; the provisional one's review (its
        empirical null, measured on that fit) and tracks' mapping are not carried over."""
        self.estimate, self._checked_s = self._fit(self._rejection), now_s
        self._pivot_dbm = float(np.mean(list(self.estimate.tx_level_db.values())))
        self.review = CalibratedReview(self.config.calibration, self.labeller)
        self.tracks_estimate = None
        self.inner = EstimationPipeline(
            self._calibrated_config(self.estimate), self.review, self._strangers
        )

    def _remap_tracks(self, replaced: EstimationPipeline, mapping: ChannelEstimate | None) -> None:
        """Move ``replaced``'s running tracks from ``mapping`` onto the new fit's: each
        track's power shifts by how much its latest held claim's mapped RSSI moves."""
        if mapping is None or self.estimate is None:
            return
        tracks = replaced.tracks
        latest: dict[str, ObservedClaim] = {}
        for claim in self._held:
            if claim.n_receivers and claim.uas_id in tracks:
                latest[claim.uas_id] = claim
        for uas_id, claim in latest.items():
            localiser = tracks[uas_id].localiser
            assert isinstance(localiser, GaussianSumLocaliser)  # _remappable
            rx, rssi = claim.rx_sysid, claim.rssi_dbm
            old = _mapped(rssi - mapping.bias_of(rx), mapping, self._pivot_dbm)
            new = _mapped(rssi - self.estimate.bias_of(rx), self.estimate, self._pivot_dbm)
            localiser.shift_power(float(np.mean(new - old)))

    def _strangers(self) -> frozenset[str]:
        """The serials the inner pipeline tracks before any alert (``tracks.
        strangers_after_claims``; none when 0)."""
        n = self.config.tracks.strangers_after_claims
        return self.labeller.strangers(n) if n > 0 else frozenset()

    def _veto_only(self) -> CalibrationConfig:
        """The review on the configured channel: the cross-check, nothing fitted."""
        return dataclasses.replace(
            self.config.calibration, empirical_null=False, honest_covariance=False
        )

    def _check_configured(self, now_s: float) -> ConfiguredChannelCheck:
        s = self.labeller.samples
        self._checked_s = now_s
        return check_configured_channel(
            s.tx_sysid,
            s.distance_m,
            s.rssi_dbm,
            self.config.rssi_sigma_db,
            self.config.detection.position_sigma_m,
            self.config.calibration.configured_alpha,
        )

    def _reject_configured(self, now_s: float, check: ConfiguredChannelCheck) -> None:
        self._configured_rejected, self._rejection = True, check
        logger.warning(
            "t=%.2f s: the channel is not the configured one (pipeline.rssi_sigma_db %.2f dB, "
            "free space): %s; calibrating on the cooperative aircraft",
            now_s,
            self.config.rssi_sigma_db,
            check.describe(),
        )

    def _may_switch(self) -> bool:
        """Until an alert is raised: a switch replays the held claims into a new pipeline,
        which cannot take over the old one's alerts and tracks (a stranger's track it starts
        again from the claims replayed)."""
        return self.inner is not None and not self.inner.alerted

    def _check_due(self, now_s: float) -> bool:
        """``refit_s`` since the channel was last checked or fitted (the configured channel
        checked again, or the fit redone)."""
        refit_s = self.config.calibration.refit_s
        return refit_s > 0.0 and now_s - self._checked_s >= refit_s

    def _refit_due(self, now_s: float) -> bool:
        """Every ``refit_s`` on a fitted channel (the tracks keep their mapping:
        ``_hold_tracks_mapping``); the configured one, kept, is not fitted."""
        return self._check_due(now_s) and self.inner is not None and self.estimate is not None

    def _hold_tracks_mapping(self) -> None:
        """While a track runs its RSSI keeps the mapping it started on: a track takes a
        changed mapping for a change of range (its transmit power a slow random walk). The
        detectors take every refit."""
        if self.inner is None or not self.inner.tracks:
            self.tracks_estimate = None
        elif self.tracks_estimate is None:
            self.tracks_estimate = self.estimate

    def _update_inflation(self, now_s: float) -> None:
        """Tracks started from now on localise with the noise the vouched claims show."""
        if self.inner is None or self.estimate is None or self.review is None:
            return
        if not self.config.calibration.honest_covariance:
            return
        if self._track_noise is None:
            inflation = self.review.localisation_inflation(now_s)
        else:
            inflation = self._track_noise.inflation(now_s)
        self.inner.config = dataclasses.replace(
            self.inner.config, localisation_noise_inflation=inflation
        )

    @property
    def compute_s(self) -> deque[float]:
        return self.inner.compute_s if self.inner is not None else deque([0.0])

    def _hold(self, claims: Sequence[ObservedClaim]) -> None:
        self._held.extend(claims)
        self._newest_held_s = max([self._newest_held_s, *(c.t_s for c in claims)])
        oldest_s = self._newest_held_s - self.config.calibration.hold_s
        while self._held and self._held[0].t_s < oldest_s:
            self._held.popleft()

    def _ready(self, now_s: float, provisional: bool = False) -> bool:
        """Enough labelled receptions for the full fit, or for the provisional one (never
        with ``provisional_samples_per_parameter`` 0)."""
        cal = self.config.calibration
        per_parameter, least = cal.samples_per_parameter, cal.min_samples
        if provisional:
            per_parameter = cal.provisional_samples_per_parameter
            least = cal.provisional_min_samples
            if per_parameter <= 0.0:
                return False
        n = len(self.labeller.samples)
        if now_s < cal.min_time_s or n < least:
            return False
        return n >= per_parameter * self.labeller.samples.n_parameters()

    def _fit(self, rejection: ConfiguredChannelCheck | None) -> ChannelEstimate:
        """Fit the channel to the labelled receptions; the decision goes to the output with
        the check that rejected the configured channel, if this fit follows one."""
        s = self.labeller.samples
        cal = self.config.calibration
        plain = dataclasses.replace(cal, elevation_knots_deg=())
        estimate = fit_channel(s.tx_sysid, s.rx_sysid, s.distance_m, s.rssi_dbm, plain)
        floor_dbm = self._floor_dbm()
        self.tested_estimate = None  # the detectors' own fit, where it is not the plain one
        if cal.elevation_knots_deg or math.isfinite(floor_dbm):
            tested = fit_channel(
                s.tx_sysid, s.rx_sysid, s.distance_m, s.rssi_dbm, cal, s.elevation_deg, floor_dbm
            )
            self.tested_estimate = None if tested == estimate else tested
        logger.info(
            "channel calibrated on %d receptions: exponent %.2f +/- %.2f, sigma %.2f dB "
            "(robust scale %.2f dB), receiver biases std %.2f dB",
            estimate.n_samples,
            estimate.exponent,
            estimate.exponent_std,
            estimate.sigma_db,
            estimate.robust_scale_db,
            float(np.std(list(estimate.rx_bias_db.values()))),
        )
        std_db = None if rejection is None else rejection.residual_std_db
        p_value = None if rejection is None else rejection.p_value
        self._decision = ChannelDecision(
            "provisional" if self.provisional else "fitted",
            estimate.n_samples,
            std_db,
            p_value,
            estimate.exponent,
            estimate.sigma_db,
        )
        return estimate

    def _floor_dbm(self) -> float:
        """The receivers' sensitivity as estimated, when the lift above it is corrected."""
        return self._floor.dbm if self.config.calibration.sensitivity_lift else -math.inf

    def _calibrated_config(self, estimate: ChannelEstimate) -> PipelineConfig:
        """The inner pipeline's config on the fit: its sigma in the mapped RSSI; with a
        detectors' fit of its own the detectors' (that fit's) and the tracks' (the plain
        fit's) as the inflation of it (module docstring)."""
        floor = self.config.calibration.sigma_floor_db
        sigma = (2.0 / estimate.exponent) * max(estimate.sigma_db, floor)
        fit = self.tested_estimate
        if fit is None:
            return dataclasses.replace(self.config, rssi_sigma_db=sigma)
        tested = min((2.0 / fit.exponent) * max(fit.sigma_db, floor), sigma)
        variance_ratio = (sigma / tested) ** 2
        if self.config.calibration.honest_covariance:
            tracks = dataclasses.replace(self.config, rssi_sigma_db=sigma)
            self._track_noise = _TrackNoise(tracks, self.labeller, variance_ratio)
        return dataclasses.replace(
            self.config, rssi_sigma_db=tested, localisation_noise_inflation=variance_ratio
        )


def _remappable(pipeline: EstimationPipeline) -> bool:
    """Whether ``pipeline`` runs tracks and each can take a changed mapping
    (``GaussianSumLocaliser.shift_power``); otherwise they start again at the switch."""
    tracks = pipeline.tracks.values()
    return bool(tracks) and all(isinstance(t.localiser, GaussianSumLocaliser) for t in tracks)


class _TrackNoise:
    """The localisers' inflation when the detectors test other RSSI than the tracks get (a
    detectors' fit of its own; module docstring): the detectors once more, on the tracks'
    RSSI with the tracks' sigma (``config``), so that the vouched claims' MLAT statistics
    (``review.py``) measure the noise of the RSSI the localisers use. Their results decide
    nothing."""

    def __init__(
        self, config: PipelineConfig, labeller: CooperativeLabeller, variance_ratio: float
    ) -> None:
        # Only MLAT is read: the censored test, whose input is the detectors' RSSI, is left out.
        detection = dataclasses.replace(config.detection, censored_window_s=0.0)
        self.config = dataclasses.replace(config, detection=detection)
        #: (the tracks' sigma / the detectors' sigma)^2: the inner pipeline's rssi_sigma_db
        #: is the detectors'.
        self.variance_ratio = variance_ratio
        # Only its vouched MLAT statistics are read: no empirical null to keep.
        cal = dataclasses.replace(config.calibration, empirical_null=False)
        self.review = CalibratedReview(cal, labeller)
        self.monitors: dict[str, TransmitterMonitor] = {}
        self._last_heard_s: dict[str, float] = {}

    def observe(self, claims: Sequence[ObservedClaim]) -> None:
        """The cycle's mapped claims (``to_free_space_all``), as the tracks see them. A
        transmitter silent for ``FORGET_AFTER_S`` is forgotten, as the inner pipeline
        forgets it: a stream of new serials must not grow the memory."""
        seen = [for_tracks(claim) for claim in claims]
        monitors = []
        for claim in seen:
            monitor = self.monitors.get(claim.uas_id)
            if monitor is None:
                monitor = self.monitors[claim.uas_id] = TransmitterMonitor(
                    claim.uas_id, self.config
                )
            monitors.append(monitor)
            last = self._last_heard_s.get(claim.uas_id, claim.t_s)
            self._last_heard_s[claim.uas_id] = max(last, claim.t_s)
        for claim, results in zip(seen, observe_batch(monitors, seen), strict=True):
            self.review(claim, results)
        if seen:
            newest_s = max(self._last_heard_s.values())
            for uas_id, last_s in list(self._last_heard_s.items()):
                if newest_s - last_s > FORGET_AFTER_S:
                    del self.monitors[uas_id], self._last_heard_s[uas_id]

    def inflation(self, now_s: float) -> float:
        """The inner pipeline's ``localisation_noise_inflation``: of the detectors' sigma."""
        return self.variance_ratio * self.review.localisation_inflation(now_s)


def make_pipeline(config: PipelineConfig) -> GcsPipeline:
    """The pipeline ``config`` asks for: calibrating when ``calibration.enabled``."""
    if config.calibration.enabled:
        return CalibratingPipeline(config)
    return EstimationPipeline(config)
