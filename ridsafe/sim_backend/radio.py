r"""The simulated Remote ID radio channel.

A transmission from vehicle s at true position x_s reaches vehicle r (r != s) with

    RSSI_r = Pt_s + dPt_s - L(d_sr) + G_2ray + G_s(u_sr) + G_r(-u_sr) + b_r + X_sr + F_sr

quantised to ``rssi_resolution_db`` (0: exact), where (``common/pathloss.py`` has the
formulas and their sources; ``common/scenario.py: RadioConfig`` the options):

- L(d) the log-distance loss, exponent ``path_loss_exponent`` (2: the free-space loss of
  DESIGN.md section 6, computed exactly as the paper's equation);
- G_2ray the two-ray ground-reflection gain (``ground_reflection``; else 0);
- G_s, G_r the antennas' gains toward each other (``antenna: dipole``: a half-wave dipole
  along each body z axis, so a banked aircraft turns its null toward its neighbours; else 0);
- dPt_s ~ N(0, tx_power_sigma_db^2) per transmitter and b_r ~ N(0, receiver_bias_sigma_db^2)
  per receiver, drawn once at construction;
- X_sr log-normal shadowing: i.i.d. N(0, sigma^2) per reception (today's default) or, with
  ``shadowing_decorrelation_m`` > 0, one Gauss-Markov process per (unordered) link whose
  correlation after the link's ends moved by D metres is exp(-D / d_corr) (Gudmundson 1991;
  D = the sum of both ends' displacements);
- F_sr small-scale fading per reception (``fading: rician``): 10 log10 |h|^2 with
  h = sqrt(K/(K+1)) + sqrt(1/(K+1)) CN(0, 1), mean power 1.

A reception is delivered when RSSI_r (before quantisation) >= the receiver sensitivity and an
independent uniform draw U_r >= the packet-loss probability. The i.i.d. shadowing and the loss
draws come from the generator given, in today's order (per transmission: the N shadowing
values, then the N loss draws); every new part draws from its own child generator
(``Generator.spawn``), so with the new options at their defaults a lockstep run is
bit-identical to one before they existed.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ridsafe.common.frozen import quick_init
from ridsafe.common.pathloss import (
    dipole_gain_dbi,
    log_distance_loss_db,
    received_power_dbm,
    two_ray_gain_db,
)
from ridsafe.common.scenario import RadioConfig

FloatArray = NDArray[np.float64]

__all__ = [
    "CorrelatedShadowing",
    "RadioChannel",
    "Reception",
    "Receptions",
    "Transmission",
    "body_z_axis",
]


@dataclass(frozen=True, slots=True)
class Transmission:
    """One ASTM F3411 frame put on the air by vehicle index ``sender``."""

    t_s: float
    sender: int
    payload: bytes


@quick_init
@dataclass(frozen=True, slots=True)
class Reception:
    receiver: int
    transmission: Transmission
    rssi_dbm: float


@dataclass(frozen=True)
class Receptions:
    """Receptions as columns, in delivery order (by transmission, then receiver): reception
    i is of transmission ``transmission[i]`` (its index in the list delivered) by vehicle
    index ``receiver[i]`` at ``rssi_dbm[i]``."""

    transmission: NDArray[np.int64]
    receiver: NDArray[np.int64]
    rssi_dbm: FloatArray

    @classmethod
    def join(
        cls, receivers_of: Sequence[NDArray[np.int64]], rssi_of: Sequence[FloatArray]
    ) -> Receptions:
        """Transmission k's receivers and strengths (``receivers_of[k]``, ``rssi_of[k]``), one
        after another."""
        if len(receivers_of) == 1:  # most ticks: one transmission
            receivers = receivers_of[0].astype(np.int64, copy=False)
            return cls(np.zeros(len(receivers), np.int64), receivers, rssi_of[0])
        counts = [len(receivers) for receivers in receivers_of]
        return cls(
            np.repeat(np.arange(len(counts), dtype=np.int64), counts),
            np.concatenate([np.zeros(0, np.int64), *receivers_of]).astype(np.int64),
            np.concatenate([np.zeros(0), *rssi_of]),
        )

    def __len__(self) -> int:
        return int(self.receiver.shape[0])

    def receptions(self, transmissions: Sequence[Transmission]) -> list[Reception]:
        """One ``Reception`` each, of the ``transmissions`` these were delivered from."""
        return list(
            map(
                Reception,
                self.receiver.tolist(),
                [transmissions[k] for k in self.transmission.tolist()],
                self.rssi_dbm.tolist(),
            )
        )


def body_z_axis(euler_rad: FloatArray) -> FloatArray:
    """``(N, 3)`` body z axes in the world frame from ``(N, 3)`` (roll, pitch, yaw), Z-Y-X
    rotation body -> world: the third column of Rz(yaw) Ry(pitch) Rx(roll)."""
    phi, theta, psi = euler_rad[:, 0], euler_rad[:, 1], euler_rad[:, 2]
    axes: FloatArray = np.stack(
        (
            np.cos(psi) * np.sin(theta) * np.cos(phi) + np.sin(psi) * np.sin(phi),
            np.sin(psi) * np.sin(theta) * np.cos(phi) - np.cos(psi) * np.sin(phi),
            np.cos(theta) * np.cos(phi),
        ),
        axis=1,
    )
    return axes


class CorrelatedShadowing:
    """Per-link Gauss-Markov shadowing (dB): S <- rho S + sqrt(1 - rho^2) sigma w with
    rho = exp(-D / decorrelation_m), D the link ends' displacement since its last draw.
    Symmetric: the link s -> r and r -> s share one value (reciprocity)."""

    def __init__(
        self, n: int, sigma_db: float, decorrelation_m: float, rng: np.random.Generator
    ) -> None:
        self.sigma_db = sigma_db
        self.decorrelation_m = decorrelation_m
        self._rng = rng
        self.value_db = np.zeros((n, n))
        # anchor_m[i, j]: where vehicle i was when link {i, j} was last drawn (NaN: never).
        self.anchor_m = np.full((n, n, 3), np.nan)

    def draw(self, sender: int, p_m: FloatArray) -> FloatArray:
        """``(N,)`` shadowing of the links sender -> every vehicle at positions ``p_m``."""
        moved_rx = np.linalg.norm(p_m - self.anchor_m[:, sender], axis=1)
        moved_tx = np.linalg.norm(p_m[sender] - self.anchor_m[sender], axis=1)
        moved = moved_rx + moved_tx
        rho = np.where(np.isnan(moved), 0.0, np.exp(-np.nan_to_num(moved) / self.decorrelation_m))
        w = self._rng.standard_normal(p_m.shape[0])
        new: FloatArray = rho * self.value_db[sender] + np.sqrt(1.0 - rho * rho) * self.sigma_db * w
        self.value_db[sender] = new
        self.value_db[:, sender] = new
        self.anchor_m[:, sender] = p_m
        self.anchor_m[sender] = p_m[sender]
        return new


def rician_fading_db(rng: np.random.Generator, k_db: float, n: int) -> FloatArray:
    """``(n,)`` draws of 10 log10 |h|^2, h Rician with factor K (mean power 1)."""
    k = 10.0 ** (k_db / 10.0)
    los = np.sqrt(k / (k + 1.0))
    scatter = np.sqrt(0.5 / (k + 1.0)) * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
    power = np.maximum(np.abs(los + scatter) ** 2, 1e-12)
    out: FloatArray = 10.0 * np.log10(power)
    return out


class RadioChannel:
    """Delivers transmissions to every other vehicle with RSSI, loss and sensitivity."""

    def __init__(
        self, config: RadioConfig, tx_power_dbm: ArrayLike, rng: np.random.Generator
    ) -> None:
        self.config = config
        nominal = np.asarray(tx_power_dbm, dtype=np.float64)
        n = nominal.shape[0]
        self._rng = rng
        bias_rng, power_rng, shadow_rng, self._fading_rng = rng.spawn(4)
        self.rx_bias_db = (
            bias_rng.normal(0.0, config.receiver_bias_sigma_db, n)
            if config.receiver_bias_sigma_db > 0.0
            else np.zeros(n)
        )
        self.tx_power_dbm = (
            nominal + power_rng.normal(0.0, config.tx_power_sigma_db, n)
            if config.tx_power_sigma_db > 0.0
            else nominal
        )
        self._shadowing = (
            CorrelatedShadowing(
                n, config.shadowing_sigma_db, config.shadowing_decorrelation_m, shadow_rng
            )
            if config.shadowing_decorrelation_m > 0.0 and config.shadowing_sigma_db > 0.0
            else None
        )
        self.delivered = 0
        self.below_sensitivity = 0
        self.lost = 0

    def mean_rssi_dbm(
        self, sender: int, p_enu_m: FloatArray, euler_rad: FloatArray | None = None
    ) -> FloatArray:
        """``(N,)`` RSSI at every vehicle without the random shadowing and fading (dB)."""
        cfg = self.config
        offset_m = p_enu_m - p_enu_m[sender]
        distance_m = np.linalg.norm(offset_m, axis=1)
        pt = self.tx_power_dbm[sender]
        if cfg.path_loss_exponent == 2.0:  # today's expression, bit for bit
            rssi = received_power_dbm(pt, distance_m, cfg.frequency_mhz)
        else:
            rssi = pt - log_distance_loss_db(distance_m, cfg.path_loss_exponent, cfg.frequency_mhz)
        if cfg.ground_reflection:
            heights_m = p_enu_m[:, 2] + cfg.antenna_height_m
            rssi = rssi + two_ray_gain_db(
                np.hypot(offset_m[:, 0], offset_m[:, 1]),
                heights_m[sender],
                heights_m,
                cfg.frequency_mhz,
            )
        if cfg.antenna == "dipole":
            axes = body_z_axis(euler_rad if euler_rad is not None else np.zeros_like(p_enu_m))
            u = offset_m / np.maximum(distance_m, 1e-9)[:, None]
            rssi = (
                rssi
                + dipole_gain_dbi(u @ axes[sender])
                + dipole_gain_dbi(np.einsum("ij,ij->i", u, axes))
            )
        if cfg.receiver_bias_sigma_db > 0.0:
            rssi = rssi + self.rx_bias_db
        out: FloatArray = rssi
        return out

    def deliver(
        self,
        transmissions: Sequence[Transmission],
        p_enu_m: FloatArray,
        euler_rad: FloatArray | None = None,
    ) -> list[Reception]:
        """Receptions of ``transmissions`` given every vehicle's position ``(N, 3)`` now (and
        attitude ``(N, 3)`` roll, pitch, yaw in rad, for antenna patterns; None: level)."""
        return self.deliver_columns(transmissions, p_enu_m, euler_rad).receptions(transmissions)

    def deliver_columns(
        self,
        transmissions: Sequence[Transmission],
        p_enu_m: FloatArray,
        euler_rad: FloatArray | None = None,
    ) -> Receptions:
        """``deliver``'s receptions as columns (the same draws, in the same order)."""
        cfg = self.config
        receivers_of: list[NDArray[np.int64]] = []
        rssi_of: list[FloatArray] = []
        n = p_enu_m.shape[0]
        for tx in transmissions:
            rssi = self.mean_rssi_dbm(tx.sender, p_enu_m, euler_rad)
            if self._shadowing is not None:
                rssi = rssi + self._shadowing.draw(tx.sender, p_enu_m)
            elif cfg.shadowing_sigma_db > 0.0:
                rssi = rssi + self._rng.normal(0.0, cfg.shadowing_sigma_db, n)
            if cfg.fading == "rician":
                rssi = rssi + rician_fading_db(self._fading_rng, cfg.rician_k_db, n)
            heard = rssi >= cfg.sensitivity_dbm
            kept = self._rng.random(n) >= cfg.packet_loss_probability
            heard[tx.sender] = False
            ok = heard & kept
            self.below_sensitivity += int(n - 1 - np.count_nonzero(heard))
            self.lost += int(np.count_nonzero(heard & ~kept))
            self.delivered += int(np.count_nonzero(ok))
            if cfg.rssi_resolution_db > 0.0:
                rssi = np.round(rssi / cfg.rssi_resolution_db) * cfg.rssi_resolution_db
            receivers = np.flatnonzero(ok)
            receivers_of.append(receivers)
            rssi_of.append(rssi[receivers])
        return Receptions.join(receivers_of, rssi_of)
