"""The RSSI-consistency detectors' memory of every claimed transmitter, stacked.

One row per transmitter's bank (``rssi_consistency.RssiConsistencyDetectors``), so the claims
of a GCS cycle go through one compiled call (``observe_batch_kernel``) instead of one each:

- ``pair_power_dbm``, ``pair_var_db2`` : (M, 256) float64, ``pair_started`` : (M, 256)
  bool: the paper's scalar Kalman filter per (receiver system id, transmitter);
- ``ring`` : (M, RING, ROW) float64 and ``ring_t`` : (M, RING) s: the window's per-claim
  sufficient statistics and their times (-inf: empty);
- ``y_ref`` : (M,) dBm, the implied-power reference of the row's first claim;
- ``params`` : (M, N_PARAMS), the row's constants (``observe_params``).

A row is taken when a bank is made and given back when it is collected (``weakref.finalize``);
full, the arrays double (banks keep their row number, never a view, so growing is safe).
"""

from __future__ import annotations

from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from ridsafe.gcs.detection.rssi_consistency_kernels import N_PARAMS, ROW

__all__ = ["PAIR_SLOTS", "RING", "RssiStatePool"]

#: One pair filter per MAVLink system id (``rx_sysid & 0xFF``).
PAIR_SLOTS = 256
#: The window keeps at most this many claims per transmitter.
RING = 64
_Array = TypeVar("_Array", NDArray[np.float64], NDArray[np.bool_])


class RssiStatePool:
    """Stacked detector memory (module docstring); ``acquire`` a row, ``release`` it."""

    pair_power_dbm: NDArray[np.float64]
    pair_var_db2: NDArray[np.float64]
    pair_started: NDArray[np.bool_]
    ring: NDArray[np.float64]
    ring_t: NDArray[np.float64]
    y_ref: NDArray[np.float64]
    params: NDArray[np.float64]

    def __init__(self, capacity: int = 16) -> None:
        self.pair_power_dbm = np.zeros((capacity, PAIR_SLOTS))
        self.pair_var_db2 = np.zeros((capacity, PAIR_SLOTS))
        self.pair_started = np.zeros((capacity, PAIR_SLOTS), dtype=bool)
        self.ring = np.zeros((capacity, RING, ROW))
        self.ring_t = np.full((capacity, RING), -np.inf)
        self.y_ref = np.zeros(capacity)
        self.params = np.zeros((capacity, N_PARAMS))
        self._free = list(range(capacity - 1, -1, -1))

    @property
    def capacity(self) -> int:
        return int(self.y_ref.shape[0])

    @property
    def in_use(self) -> int:
        return self.capacity - len(self._free)

    def acquire(self, params: NDArray[np.float64]) -> int:
        """A fresh row (empty filters and window) with constants ``params`` (N_PARAMS,)."""
        if not self._free:
            self._grow()
        row = self._free.pop()
        self.pair_power_dbm[row] = 0.0
        self.pair_var_db2[row] = 0.0
        self.pair_started[row] = False
        self.ring[row] = 0.0
        self.ring_t[row] = -np.inf
        self.y_ref[row] = 0.0
        self.params[row] = params
        return row

    def release(self, row: int) -> None:
        self._free.append(row)

    def _grow(self) -> None:
        old = self.capacity
        new = max(2 * old, 1)

        def grown(a: _Array, fill: float | bool) -> _Array:
            out: _Array = np.full((new, *a.shape[1:]), fill, dtype=a.dtype)
            out[:old] = a
            return out

        self.pair_power_dbm = grown(self.pair_power_dbm, 0.0)
        self.pair_var_db2 = grown(self.pair_var_db2, 0.0)
        self.pair_started = grown(self.pair_started, False)
        self.ring = grown(self.ring, 0.0)
        self.ring_t = grown(self.ring_t, -np.inf)
        self.y_ref = grown(self.y_ref, 0.0)
        self.params = grown(self.params, 0.0)
        self._free.extend(range(new - 1, old - 1, -1))
