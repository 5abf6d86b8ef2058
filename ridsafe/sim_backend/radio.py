"""The simulated Remote ID radio channel.

A transmission from vehicle s at true position x_s reaches vehicle r (r != s) with

    RSSI_r = Pt_s - FSPL(||x_r - x_s||, f) + X_r,        X_r ~ N(0, sigma^2) (shadowing)

(free-space path loss, DESIGN.md section 6) and is delivered when RSSI_r >= the receiver
sensitivity and an independent uniform draw U_r >= the packet-loss probability. Draws come
from one generator spawned from the scenario seed, in a fixed order (per transmission: the
N shadowing values, then the N loss draws), so a lockstep run is bit-reproducible.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ridsafe.common.frozen import quick_init
from ridsafe.common.pathloss import received_power_dbm
from ridsafe.common.scenario import RadioConfig

FloatArray = NDArray[np.float64]


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


class RadioChannel:
    """Delivers transmissions to every other vehicle with RSSI, loss and sensitivity."""

    def __init__(
        self, config: RadioConfig, tx_power_dbm: ArrayLike, rng: np.random.Generator
    ) -> None:
        self.config = config
        self.tx_power_dbm = np.asarray(tx_power_dbm, dtype=np.float64)
        self._rng = rng
        self.delivered = 0
        self.below_sensitivity = 0
        self.lost = 0

    def deliver(
        self, transmissions: Sequence[Transmission], p_enu_m: FloatArray
    ) -> list[Reception]:
        """Receptions of ``transmissions`` given every vehicle's position ``(N, 3)`` now."""
        receptions: list[Reception] = []
        n = p_enu_m.shape[0]
        for tx in transmissions:
            distance_m = np.linalg.norm(p_enu_m - p_enu_m[tx.sender], axis=1)
            rssi = received_power_dbm(
                self.tx_power_dbm[tx.sender], distance_m, self.config.frequency_mhz
            )
            if self.config.shadowing_sigma_db > 0.0:
                rssi = rssi + self._rng.normal(0.0, self.config.shadowing_sigma_db, n)
            heard = rssi >= self.config.sensitivity_dbm
            kept = self._rng.random(n) >= self.config.packet_loss_probability
            heard[tx.sender] = False
            ok = heard & kept
            self.below_sensitivity += int(n - 1 - np.count_nonzero(heard))
            self.lost += int(np.count_nonzero(heard & ~kept))
            self.delivered += int(np.count_nonzero(ok))
            receptions.extend(Reception(int(r), tx, float(rssi[r])) for r in np.flatnonzero(ok))
        return receptions
