"""Configuration of the GCS's channel calibration (YAML ``pipeline.calibration``).

``auto`` by default: the configured channel (``pipeline.rssi_sigma_db``, free space) is kept
as long as the cooperative aircraft's receptions fit it, and replaced by the fitted one the
first time they do not. On (``true``), the configured channel is only a starting point the
calibration replaces once it has enough labelled receptions for the parameters it fits
(``calibration/pipeline.py``). Off, it is trusted whatever the receptions say.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Literal

from ridsafe.common.checks import check_non_negative, check_positive
from ridsafe.common.errors import FieldValueError

__all__ = ["CalibrationConfig"]


@dataclass(frozen=True)
class CalibrationConfig:
    """Online channel estimation from benign-to-benign receptions."""

    #: false: the configured channel, trusted; true: the fitted channel; ``auto``: the
    #: configured channel while the cooperative receptions fit it (tested from
    #: ``configured_min_samples`` on, then every ``refit_s`` until an alert), the fitted
    #: one from the first check that rejects it. In both calibrating modes the cooperative
    #: cross-check (``cooperative_veto``) runs; the empirical null and the localisation
    #: inflation only on the fitted channel.
    enabled: bool | Literal["auto"] = "auto"
    #: ``auto``: the configured channel is tested (``channel_fit.check_configured_channel``)
    #: from ``configured_min_samples`` labelled receptions on (the test fits a level per
    #: transmitter only), each cycle until decided: kept at once when the chi-square's
    #: p-value is at least ``configured_accept_p``, rejected (the channel fitted) when it is
    #: below ``configured_alpha``; in between the test waits for more receptions, up to the
    #: fit's warm-up, where ``configured_alpha`` alone decides. Later checks (every
    #: ``refit_s``) reject below ``configured_alpha``.
    configured_min_samples: int = 30
    configured_accept_p: float = 0.05
    configured_alpha: float = 1e-3
    #: Labelled receptions needed before the channel is estimated and detection starts:
    #: ``samples_per_parameter`` for each parameter the fit has (1 exponent + a bias per
    #: receiver + a level per transmitter seen), and never fewer than ``min_samples``. The
    #: fit's precision follows the receptions per parameter, so the warm-up scales with the
    #: fleet (16 aircraft: 33 parameters, 297 receptions; 8 aircraft: 153).
    samples_per_parameter: float = 9.0
    min_samples: int = 100
    #: A provisional fit before that, from this many labelled receptions per parameter (at
    #: least ``provisional_min_samples``): the estimation pipeline starts on it, so that
    #: strangers' regions and the first alerts need not wait for the full warm-up (8
    #: aircraft: 85 receptions instead of 153). At the full warm-up a pipeline on the full
    #: fit replaces it, the held claims replayed, with the alerts raised meanwhile standing
    #: (``pipeline.py``). 0: no provisional stage.
    provisional_samples_per_parameter: float = 0.0
    provisional_min_samples: int = 50
    #: ... and no earlier than this (sim seconds), so several geometries are seen.
    min_time_s: float = 2.0
    #: At the full warm-up the provisional pipeline's running tracks go on in the new one
    #: on the full fit's mapping, each track's transmit power shifted by how much its latest
    #: claim's mapped RSSI moved, and the held claims they already took not given again
    #: (``pipeline.py``; estimator ``rssi_imm`` only: other estimators' tracks start again).
    #: False: they start again from the held claims. Off by default: over the robustness
    #: sweep it meets exponent 3's bars at 8 aircraft but keeps tracks the provisional fit
    #: placed wrong on the urban preset (docs/results/robustness.md, session 59).
    provisional_keeps_tracks: bool = False
    #: A claim is a cooperative aircraft's when it lies within this of one receiver's own
    #: reported position (reported within ``match_age_s`` of the claim), ...
    match_m: float = 10.0
    match_age_s: float = 1.0
    #: ... consistently: at least this many matches, all but ``max_mismatch_fraction`` of
    #: them with the same receiver.
    min_matches: int = 3
    max_mismatch_fraction: float = 0.2
    #: The cooperative cross-check: a claim of a serial labelled cooperative that lies within
    #: ``vouch_m`` of where its own aircraft last reported being (from its observation
    #: reports) is that aircraft telling the truth, so it raises no alert, whatever the
    #: detectors say of a channel they model imperfectly. A spoofer using the serial but
    #: claiming elsewhere is not vouched for.
    cooperative_veto: bool = True
    vouch_m: float = 30.0
    #: The empirical null (``review.py``): an unvouched claim alerts only above
    #: ``null_margin`` times the largest statistic of the vouched claims of the last
    #: ``null_window_s`` (and above the detector's own threshold).
    empirical_null: bool = True
    null_margin: float = 1.25
    null_window_s: float = 60.0
    null_min_claims: int = 20
    #: Inflate the localisers' noise by the vouched claims' MLAT statistics (``review.py``).
    honest_covariance: bool = True
    #: Receptions by receivers lower than this (m above the ground) are left out of the fit
    #: and of detection and localisation (0 keeps them).
    min_receiver_height_m: float = 0.0
    #: The antennas' gain off level, learned: a second fit gives the links' elevation
    #: (|asin(dz / d)|, both antennas' patterns together) a gain, piecewise linear between
    #: these knots (degrees, ascending, the first 0: level links carry the levels), each
    #: knot's value with prior N(0, ``elevation_gain_prior_std_db``^2); the detectors test
    #: each claim on its RSSI less the gain at its receivers' elevation from the claimed
    #: position (``pipeline.py``). An installed antenna is not isotropic: a vertical
    #: half-wave dipole loses about 4 dB at 45 degrees at each end. The knots' parameters do
    #: not count toward the warm-up (``samples_per_parameter``): their prior holds them at
    #: 0 dB until steep links are heard. Empty: no elevation gain.
    elevation_knots_deg: tuple[float, ...] = (0.0, 10.0, 20.0, 30.0, 45.0, 60.0, 90.0)
    elevation_gain_prior_std_db: float = 10.0
    #: A knot's gain is used only when it is at least this many of its standard errors
    #: from 0 dB; the others are held at 0 (``channel_fit.py``). 0: every knot as fitted.
    elevation_gain_min_z: float = 3.0
    #: Receptions near the receivers' sensitivity: nothing weaker is reported, so what is
    #: runs above the link's mean. The fit and the detectors expect that lift, with the
    #: sensitivity taken as the weakest RSSI reported (``censoring.py``); the tracks do not.
    sensitivity_lift: bool = True
    #: Priors: path-loss exponent N(prior, std^2), each receiver's bias N(0, std^2) (dB).
    exponent_prior: float = 2.0
    exponent_prior_std: float = 1.0
    receiver_bias_prior_std_db: float = 3.0
    #: Student-t degrees of freedom of the robust fit (iteratively reweighted least squares).
    student_dof: float = 4.0
    #: The noise std the pipeline is given never goes below this (dB).
    sigma_floor_db: float = 0.5
    #: Labelled receptions kept (the oldest dropped).
    max_samples: int = 20_000
    #: Refit the channel (exponent, biases: the RSSI mapping) on the labelled receptions this
    #: often (s) until a track runs (``pipeline.py``); the noise std the detectors were built
    #: with stays, the empirical null and the localisation inflation (``review.py``) follow
    #: it. 0: fit once. The first fit sees aircraft on the ground at their depots, later
    #: ones the airborne channel. ``auto`` tests the configured channel again this often.
    refit_s: float = 10.0
    #: Claims held while calibrating (seconds of history replayed once calibrated).
    hold_s: float = 10.0

    def __post_init__(self) -> None:
        names = ("min_samples", "min_matches", "max_samples", "null_min_claims")
        for name in (*names, "configured_min_samples", "provisional_min_samples"):
            if getattr(self, name) < 1:
                raise FieldValueError(name, f"expected >= 1, got {getattr(self, name)}")
        for name in ("match_m", "match_age_s", "vouch_m", "exponent_prior", "exponent_prior_std"):
            check_positive(name, getattr(self, name))
        for name in ("null_window_s", "null_margin"):
            check_positive(name, getattr(self, name))
        knots = self.elevation_knots_deg
        if knots and (
            knots[0] != 0.0
            or len(knots) < 2
            or any(b <= a for a, b in itertools.pairwise(knots))
            or knots[-1] > 90.0
        ):
            raise FieldValueError(
                "elevation_knots_deg",
                f"expected 0 first, then ascending up to 90 degrees, got {list(knots)}",
            )
        for name in (
            "receiver_bias_prior_std_db",
            "elevation_gain_prior_std_db",
            "student_dof",
            "sigma_floor_db",
        ):
            check_positive(name, getattr(self, name))
        check_non_negative("samples_per_parameter", self.samples_per_parameter)
        check_non_negative(
            "provisional_samples_per_parameter", self.provisional_samples_per_parameter
        )
        check_non_negative("elevation_gain_min_z", self.elevation_gain_min_z)
        check_non_negative("min_time_s", self.min_time_s)
        check_non_negative("hold_s", self.hold_s)
        check_non_negative("refit_s", self.refit_s)
        check_non_negative("min_receiver_height_m", self.min_receiver_height_m)
        if not 0.0 < self.configured_alpha <= self.configured_accept_p < 1.0:
            raise FieldValueError(
                "configured_alpha",
                "expected 0 < configured_alpha <= configured_accept_p < 1, got "
                f"{self.configured_alpha} and {self.configured_accept_p}",
            )
        if not 0.0 <= self.max_mismatch_fraction < 0.5:
            raise FieldValueError(
                "max_mismatch_fraction", f"expected 0 <= f < 0.5, got {self.max_mismatch_fraction}"
            )
