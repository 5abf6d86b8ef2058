r"""Free-space path loss: the paper's received-power model and its inverses.

The paper's model (free space; paper eq. (8), ``eq:fspl_rewrite``)::

    Pr = Pt - 20 log10(d_km) - 20 log10(f_MHz) - 32.44            [dBm, km, MHz]

With d in metres, 20 log10(d_km) = 20 log10(d_m) - 60, so::

    Pr = Pt - 20 log10(d_m) - L1(f),    L1(f) = 20 log10(f_MHz) + 32.44 - 60

L1 is the loss over the first metre: L1(2400 MHz) = 40.0442 dB (:data:`LOSS_AT_1M_2400MHZ_DB`).
The paper's multilateration objective (eq. (9)) and the authors' detectors use it rounded,
Pr = Pt - 20 log10(d_m) - 40.04 (:data:`DETECTOR_LOSS_AT_1M_DB`); the two differ by 0.0042 dB,
far below any RSSI noise.
Which constant each function uses:

- :func:`received_power_dbm`, :func:`distance_m_from_power`, :func:`loss_at_1m_db`: the exact
  L1(f) from the paper's equation (at any frequency).
- :func:`implied_tx_power_dbm`: its ``loss_1m_db`` argument, default the detectors' rounded
  40.04, so detection reproduces the reference detectors; pass :data:`LOSS_AT_1M_2400MHZ_DB`
  to invert :func:`received_power_dbm` exactly.

Distances below :data:`MIN_DISTANCE_M` (1 m) are clamped to it: the far-field model means nothing
closer, and log10(0) never happens. Negative distances raise ValueError; NaN propagates.
All functions are vectorised: array arguments broadcast and the result has the broadcast shape.

Beyond free space (the simulated radio's options, ``sim_backend/radio.py``):

- log-distance loss (Rappaport, *Wireless Communications*, 2nd ed., eq. 4.68)::

      L(d) = L1(f) + 10 n log10(max(d, 1 m)),    n = 2 is free space

  (:func:`log_distance_loss_db`);
- the two-ray ground-reflection model over flat ground (Rappaport section 4.6): the direct
  ray and the ray reflected at the ground with coefficient Gamma add coherently::

      G_2ray = 20 log10 | 1 + Gamma (d_los / d_ref) exp(-j 2 pi (d_ref - d_los) / lambda) |

  with d_ref the length of the path via the mirror image of the transmitter below the
  ground; Gamma = -1 (grazing incidence; :func:`two_ray_gain_db`);
- the half-wave dipole's power gain at angle theta from its axis (Balanis, *Antenna
  Theory*, 4th ed., eq. 4-84)::

      G(theta) = 1.641 [cos(pi/2 cos theta) / sin theta]^2      (2.15 dBi broadside)

  (:func:`dipole_gain_dbi`).
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "DB_PER_LN",
    "DETECTOR_LOSS_AT_1M_DB",
    "FSPL_CONSTANT_DB",
    "GROUND_REFLECTION_COEFFICIENT",
    "LOSS_AT_1M_2400MHZ_DB",
    "MIN_DISTANCE_M",
    "RID_FREQUENCY_MHZ",
    "dipole_gain_dbi",
    "distance_m_from_power",
    "implied_tx_power_dbm",
    "log_distance_loss_db",
    "loss_at_1m_db",
    "received_power_dbm",
    "two_ray_gain_db",
]

FloatArray = NDArray[np.float64]

#: The free-space constant of the paper's equation, for d in km and f in MHz.
FSPL_CONSTANT_DB = 32.44
#: Remote ID broadcast frequency used throughout (2.4 GHz band).
RID_FREQUENCY_MHZ = 2400.0
#: Loss over the first metre at 2400 MHz, exact from the paper's equation: 40.0442 dB.
LOSS_AT_1M_2400MHZ_DB = 20.0 * math.log10(RID_FREQUENCY_MHZ) + FSPL_CONSTANT_DB - 60.0
#: The rounded first-metre loss of the authors' reference detectors.
DETECTOR_LOSS_AT_1M_DB = 40.04
#: Distances are clamped to at least this (metres) before taking log10.
MIN_DISTANCE_M = 1.0
#: The slope of the loss in ln(distance): d(20 log10 d) / d(ln d) = 20 / ln 10 = 8.686 dB.
DB_PER_LN = 20.0 / math.log(10.0)


def loss_at_1m_db(frequency_mhz: ArrayLike = RID_FREQUENCY_MHZ) -> FloatArray:
    """L1(f) = 20 log10(f_MHz) + 32.44 - 60 dB, the paper's loss over the first metre."""
    value: object = frequency_mhz  # (numpy's ArrayLike spells float as complex)
    if isinstance(value, float):  # a radio's one frequency: every reception of a run
        return _loss_at_1m_of(value)
    return _loss_at_1m(frequency_mhz)


@functools.lru_cache(maxsize=16)
def _loss_at_1m_of(frequency_mhz: float) -> FloatArray:
    return _loss_at_1m(frequency_mhz)


def _loss_at_1m(frequency_mhz: ArrayLike) -> FloatArray:
    f = np.asarray(frequency_mhz, dtype=np.float64)
    if np.any(f <= 0.0):
        raise ValueError(f"frequency_mhz must be > 0, got {frequency_mhz!r}")
    loss: FloatArray = 20.0 * np.log10(f) + FSPL_CONSTANT_DB - 60.0
    return loss


def _log_distance_db(distance_m: ArrayLike) -> FloatArray:
    """20 log10(max(d, MIN_DISTANCE_M)); raises on negative distances."""
    d = np.asarray(distance_m, dtype=np.float64)
    if np.any(d < 0.0):
        raise ValueError(f"distance_m must be >= 0, got min {float(np.nanmin(d))!r}")
    out: FloatArray = 20.0 * np.log10(np.maximum(d, MIN_DISTANCE_M))
    return out


def received_power_dbm(
    tx_power_dbm: ArrayLike, distance_m: ArrayLike, frequency_mhz: ArrayLike = RID_FREQUENCY_MHZ
) -> FloatArray:
    """Pr = Pt - 20 log10(max(d_m, 1 m)) - L1(f): received power in dBm (exact constant)."""
    pt = np.asarray(tx_power_dbm, dtype=np.float64)
    pr: FloatArray = pt - _log_distance_db(distance_m) - loss_at_1m_db(frequency_mhz)
    return pr


def distance_m_from_power(
    rx_power_dbm: ArrayLike, tx_power_dbm: ArrayLike, frequency_mhz: ArrayLike = RID_FREQUENCY_MHZ
) -> FloatArray:
    """d = 10^((Pt - Pr - L1(f)) / 20), the inverse of :func:`received_power_dbm`, in metres.

    Clamped to at least :data:`MIN_DISTANCE_M`: a received power above the 1 m level means
    "closer than the model resolves", consistent with the clamp in :func:`received_power_dbm`.
    """
    pr = np.asarray(rx_power_dbm, dtype=np.float64)
    pt = np.asarray(tx_power_dbm, dtype=np.float64)
    exponent = (pt - pr - loss_at_1m_db(frequency_mhz)) / 20.0
    d: FloatArray = np.maximum(10.0**exponent, MIN_DISTANCE_M)
    return d


def implied_tx_power_dbm(
    rssi_dbm: ArrayLike, distance_m: ArrayLike, loss_1m_db: ArrayLike = DETECTOR_LOSS_AT_1M_DB
) -> FloatArray:
    """Pt = RSSI + 20 log10(max(d_m, 1 m)) + L1: the transmit power a reception implies.

    Used by spoofing detection with d the distance to the *claimed* position: an honest
    transmitter implies the same Pt at every receiver, a spoofer does not. ``loss_1m_db``
    defaults to the reference detectors' rounded 40.04 dB.
    """
    rssi = np.asarray(rssi_dbm, dtype=np.float64)
    pt: FloatArray = rssi + _log_distance_db(distance_m) + np.asarray(loss_1m_db, np.float64)
    return pt


#: Ground reflection coefficient of the two-ray model (grazing incidence).
GROUND_REFLECTION_COEFFICIENT = -1.0
#: Speed of light (m/s), for the wavelength of the two-ray phase.
SPEED_OF_LIGHT_M_S = 299_792_458.0
#: Floor of the two-ray gain (dB): a perfect null would give -inf (real ground is rough).
TWO_RAY_FLOOR_DB = -30.0
#: Half-wave dipole directivity (1.641, 2.15 dBi) and the floor of its pattern nulls (dBi):
#: the airframe and the ground fill the nulls of a real installed antenna.
DIPOLE_DIRECTIVITY = 1.641
DIPOLE_FLOOR_DBI = -20.0


def log_distance_loss_db(
    distance_m: ArrayLike,
    exponent: float = 2.0,
    frequency_mhz: ArrayLike = RID_FREQUENCY_MHZ,
) -> FloatArray:
    """L(d) = L1(f) + 10 n log10(max(d, 1 m)) (dB); n = 2 equals the free-space loss."""
    if not exponent > 0.0:
        raise ValueError(f"exponent must be > 0, got {exponent!r}")
    loss: FloatArray = (exponent / 2.0) * _log_distance_db(distance_m) + loss_at_1m_db(
        frequency_mhz
    )
    return loss


def two_ray_gain_db(
    horizontal_m: ArrayLike,
    tx_height_m: ArrayLike,
    rx_height_m: ArrayLike,
    frequency_mhz: float = RID_FREQUENCY_MHZ,
) -> FloatArray:
    """Two-ray gain over the direct ray alone (dB), floored at :data:`TWO_RAY_FLOOR_DB`.

    Heights above the flat ground (clamped to >= 0); ``horizontal_m`` the ground distance.
    """
    x = np.asarray(horizontal_m, dtype=np.float64)
    ht = np.maximum(np.asarray(tx_height_m, dtype=np.float64), 0.0)
    hr = np.maximum(np.asarray(rx_height_m, dtype=np.float64), 0.0)
    d_los = np.maximum(np.hypot(x, ht - hr), MIN_DISTANCE_M)
    d_ref = np.maximum(np.hypot(x, ht + hr), MIN_DISTANCE_M)
    wavelength_m = SPEED_OF_LIGHT_M_S / (frequency_mhz * 1e6)
    phase = 2.0 * np.pi * (d_ref - d_los) / wavelength_m
    field = 1.0 + GROUND_REFLECTION_COEFFICIENT * (d_los / d_ref) * np.exp(-1j * phase)
    power = np.maximum(np.abs(field) ** 2, 10.0 ** (TWO_RAY_FLOOR_DB / 10.0))
    gain: FloatArray = 10.0 * np.log10(power)
    return gain


def dipole_gain_dbi(cos_theta: ArrayLike) -> FloatArray:
    """Half-wave dipole gain (dBi) at angle theta from its axis, floored at
    :data:`DIPOLE_FLOOR_DBI`; ``cos_theta`` in [-1, 1]."""
    c = np.clip(np.asarray(cos_theta, dtype=np.float64), -1.0, 1.0)
    sin2 = np.maximum(1.0 - c * c, 1e-12)
    pattern = np.cos(0.5 * np.pi * c) ** 2 / sin2
    power = np.maximum(DIPOLE_DIRECTIVITY * pattern, 10.0 ** (DIPOLE_FLOOR_DBI / 10.0))
    gain: FloatArray = 10.0 * np.log10(power)
    return gain
