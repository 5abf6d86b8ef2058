"""What spoofers and ghosts say on Remote ID, and how loud: the claim and tx-power kinds of
``ridsafe.common.adversary`` as functions of sim time and the transmitter's true state.

``Claim.state(now_s, p_enu_m, v_enu_m_s)`` gives the claimed (position, velocity) in scenario
ENU:

- ``offset``: truth + a constant offset (the paper's spoofer), true velocity;
- ``drift``: truth until ``start_s``, then + ``rate_enu_m_s`` per second, the offset capped at
  ``max_offset_m``; the claimed velocity carries the rate while the lie grows, so the claim
  is kinematically consistent;
- ``mimic``: where the target aircraft really was ``delay_s`` ago (``TrackHistory``);
- ``fixed``: hovering at ``at_enu_m``;
- ``waypoints``: a made-up constant-speed path (a ghost's aircraft);
- ``truth``: the true state (a bystander's honest broadcast).

``TxPowerDraw.next_dbm()`` gives the power of the next message (a fixed value, or a fresh
normal draw from its own seeded stream for ``random``).
"""

from __future__ import annotations

import bisect
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.adversary import ClaimConfig, TxPowerConfig
from ridsafe.sim_backend.adversary_motion import WaypointPath

FloatArray = NDArray[np.float64]
State = tuple[FloatArray, FloatArray]


class TrackHistory:
    """Recorded true (t, position, velocity) of one vehicle, queried at past times."""

    def __init__(self) -> None:
        self.t_s: list[float] = []
        self.p_enu_m: list[FloatArray] = []
        self.v_enu_m_s: list[FloatArray] = []

    def record(self, now_s: float, p_enu_m: FloatArray, v_enu_m_s: FloatArray) -> None:
        if self.t_s and now_s <= self.t_s[-1]:
            return
        self.t_s.append(now_s)
        self.p_enu_m.append(np.array(p_enu_m, dtype=np.float64))
        self.v_enu_m_s.append(np.array(v_enu_m_s, dtype=np.float64))

    def at(self, t_s: float) -> State:
        """The last record at or before ``t_s`` (the first one before the history starts)."""
        if not self.t_s:
            return np.zeros(3), np.zeros(3)
        k = max(bisect.bisect_right(self.t_s, t_s) - 1, 0)
        return self.p_enu_m[k].copy(), self.v_enu_m_s[k].copy()


class Claim:
    """The claimed state of one transmitter (module docstring)."""

    def __init__(self, config: ClaimConfig, target: TrackHistory | None = None) -> None:
        self.config = config
        self.target = target
        self._path: WaypointPath | None = None
        if config.kind == "waypoints":
            assert config.waypoints_enu_m is not None and config.speed_m_s is not None
            self._path = WaypointPath(config.waypoints_enu_m, config.speed_m_s, bool(config.loop))
        self._claimers: dict[str, Callable[[float, FloatArray, FloatArray], State]] = {
            "offset": self._offset,
            "drift": self._drift,
            "mimic": self._mimic,
            "fixed": self._fixed,
            "waypoints": self._waypoints,
            "truth": self._truth,
        }

    def state(self, now_s: float, p_enu_m: FloatArray, v_enu_m_s: FloatArray) -> State:
        return self._claimers[self.config.kind](now_s, p_enu_m, v_enu_m_s)

    def _offset(self, now_s: float, p: FloatArray, v: FloatArray) -> State:
        offset = np.asarray(self.config.offset_enu_m, dtype=np.float64)
        claimed: FloatArray = p + offset
        return claimed, v

    def drift_offset_enu_m(self, now_s: float) -> tuple[FloatArray, bool]:
        """(offset, still growing) of a ``drift`` claim at ``now_s``."""
        rate = np.asarray(self.config.rate_enu_m_s, dtype=np.float64)
        elapsed_s = max(now_s - (self.config.start_s or 0.0), 0.0)
        offset = rate * elapsed_s
        cap = self.config.max_offset_m
        norm = float(np.linalg.norm(offset))
        if cap is not None and norm > cap:
            return offset * (cap / norm), False
        return offset, elapsed_s > 0.0

    def _drift(self, now_s: float, p: FloatArray, v: FloatArray) -> State:
        offset, growing = self.drift_offset_enu_m(now_s)
        rate = np.asarray(self.config.rate_enu_m_s, dtype=np.float64)
        claimed_v: FloatArray = v + rate if growing else v
        claimed: FloatArray = p + offset
        return claimed, claimed_v

    def _mimic(self, now_s: float, p: FloatArray, v: FloatArray) -> State:
        assert self.target is not None
        return self.target.at(now_s - (self.config.delay_s or 0.0))

    def _fixed(self, now_s: float, p: FloatArray, v: FloatArray) -> State:
        return np.asarray(self.config.at_enu_m, dtype=np.float64), np.zeros(3)

    def _waypoints(self, now_s: float, p: FloatArray, v: FloatArray) -> State:
        assert self._path is not None
        return self._path.target(now_s)

    def _truth(self, now_s: float, p: FloatArray, v: FloatArray) -> State:
        return p.copy(), v.copy()


class TxPowerDraw:
    """The power of each message of one transmitter."""

    def __init__(self, config: TxPowerConfig, draw: np.random.Generator) -> None:
        self.config = config
        self._draw = draw

    def next_dbm(self) -> float:
        if self.config.kind == "fixed":
            return self.config.mean_power_dbm
        assert self.config.sigma_db is not None
        return float(self._draw.normal(self.config.mean_power_dbm, self.config.sigma_db))
