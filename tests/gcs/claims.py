"""Observed claims for GCS tests: one broadcast heard by receivers 1..k at one instant."""

from __future__ import annotations

import numpy as np

from ridsafe.common.pathloss import received_power_dbm
from ridsafe.gcs.pipeline_api import ObservedClaim, readonly


def observed_claim(
    uas_id: str, t_s: float, claimed_enu_m: np.ndarray, rx_enu_m: np.ndarray, rssi_dbm: np.ndarray,
    rx_ids: np.ndarray | None = None,
) -> ObservedClaim:  # fmt: skip
    """``uas_id`` claiming ``claimed_enu_m``, heard by receivers ``rx_ids`` (default 1..k) at
    ``rx_enu_m`` at ``t_s``."""
    k = rx_enu_m.shape[0]
    return ObservedClaim(
        uas_id,
        t_s,
        readonly(claimed_enu_m),
        None,
        np.arange(1, k + 1, dtype=np.int64) if rx_ids is None else rx_ids,
        readonly(rx_enu_m),
        readonly(np.full(k, t_s)),
        readonly(rssi_dbm),
    )


def noisy_claim(
    t_s: float, p_enu_m: np.ndarray, rx_enu_m: np.ndarray, rng: np.random.Generator,
    sigma_db: float = 1.0,
) -> ObservedClaim:  # fmt: skip
    """An honest 20 dBm transmitter at ``p_enu_m``: free-space RSSI plus N(0, sigma_db)."""
    d_m = np.linalg.norm(rx_enu_m - p_enu_m, axis=1)
    rssi = received_power_dbm(20.0, d_m) + rng.normal(0, sigma_db, rx_enu_m.shape[0])
    return observed_claim("S", t_s, p_enu_m, rx_enu_m, rssi)


def free_space_claim(
    uas_id: str, t_s: float, claimed_enu_m: list[float], rx_enu_m: dict[int, list[float]]
) -> ObservedClaim:
    """``uas_id`` heard as a 20 dBm transmitter exactly at its claim, without noise, by the
    receivers ``rx_enu_m`` (id -> position)."""
    ids = np.array(sorted(rx_enu_m), dtype=np.int64)
    p_m = np.array([rx_enu_m[i] for i in sorted(rx_enu_m)])
    d_m = np.linalg.norm(p_m - np.array(claimed_enu_m), axis=1)
    rssi = received_power_dbm(20.0, np.maximum(d_m, 1.0))
    return observed_claim(uas_id, t_s, np.array(claimed_enu_m), p_m, rssi, ids)
