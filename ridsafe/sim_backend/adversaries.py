"""The scenario's adversaries inside the sim: spoofers (vehicles N+1..N+S; those that claim
the truth are bystanders) and ghost transmitters (after them), for
``ridsafe.sim_backend.world.SimBackend``.

Per adversary: its mission (``adversary_motion``; a ghost's transmitter holds its position,
hovering when above ``GHOST_HOVER_MIN_Z_M``, else standing on the ground disarmed), its
broadcaster (``spoofer.SpooferBroadcaster`` with its claim, ``adversary_claim``), and the
power of each of its messages (``TxPowerDraw``; None: the channel's fixed per-vehicle power).
Mimicked aircraft have their true state recorded every tick (``TrackHistory``).

Seeds: the first spoofer's broadcast phase comes from the stream ``sim/spoofer`` as before;
further spoofers and ghosts from ``sim/spoofer/<serial>``, powers from
``sim/tx-power/<serial>``, so adding an adversary leaves the others' draws alone.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ridsafe.common import rng
from ridsafe.common.adversary import (
    AdversaryRole,
    ClaimConfig,
    GhostConfig,
    SpooferConfig,
    TxPowerConfig,
    silent_at,
)
from ridsafe.common.scenario import Scenario
from ridsafe.sim_backend.adversary_claim import Claim, TrackHistory, TxPowerDraw
from ridsafe.sim_backend.adversary_motion import Mission, make_mission
from ridsafe.sim_backend.spoofer import SpooferBroadcaster, StraightLineMission

FloatArray = NDArray[np.float64]
GHOST_HOVER_MIN_Z_M = 1.0

PositionOf = Callable[[int], FloatArray]


@dataclass
class Adversary:
    """One spoofer or ghost transmitter, vehicle index ``index`` (sysid ``index + 1``)."""

    index: int
    serial: str
    role: AdversaryRole
    broadcaster: SpooferBroadcaster
    power: TxPowerDraw | None
    airborne: bool  # launched in AUTO (a ghost on the ground is not)
    last_tx_power_dbm: float | None = None


class Adversaries:
    """Every adversary of ``scenario`` (see the module docstring)."""

    def __init__(self, scenario: Scenario, position_of: PositionOf) -> None:
        self.scenario = scenario
        self.position_of = position_of
        n = len(scenario.aircraft)
        self.histories: dict[int, TrackHistory] = {}
        self.items: list[Adversary] = []
        for k, spoofer in enumerate(scenario.all_spoofers):
            claim = spoofer.resolved_claim
            self.items.append(
                Adversary(
                    n + k,
                    spoofer.serial,
                    spoofer.role,
                    self._broadcaster(spoofer.serial, claim, spoofer, first=k == 0),
                    self._power(spoofer.serial, spoofer.tx_power),
                    True,
                )
            )
        first_ghost = n + len(scenario.all_spoofers)
        for k, ghost in enumerate(scenario.ghosts):
            self.items.append(
                Adversary(
                    first_ghost + k,
                    ghost.serial,
                    AdversaryRole.GHOST,
                    self._broadcaster(ghost.serial, ghost.claim, ghost, first=False),
                    self._power(ghost.serial, ghost.tx_power),
                    ghost.transmitter_enu_m[2] >= GHOST_HOVER_MIN_Z_M,
                )
            )
        self.by_index = {a.index: a for a in self.items}

    # -- construction ---------------------------------------------------------------------

    def _index_of_serial(self, serial: str) -> int:
        serials = [a.serial for a in self.scenario.aircraft]
        return serials.index(serial)

    def _broadcaster(
        self, serial: str, claim: ClaimConfig, entry: SpooferConfig | GhostConfig, first: bool
    ) -> SpooferBroadcaster:
        scenario = self.scenario
        stream = "sim/spoofer" if first else f"sim/spoofer/{serial}"
        phase = float(rng.stream(scenario.seed, stream).uniform(0.0, 1.0))
        if isinstance(entry, GhostConfig):
            t = entry.transmitter_enu_m
            ground = (t[0], t[1], 0.0)
        else:
            p0 = entry.resolved_motion.initial_enu_m
            ground = (p0[0], p0[1], 0.0)
        offset = claim.offset_enu_m if claim.kind == "offset" else (0.0, 0.0, 0.0)
        plain_offset = isinstance(entry, SpooferConfig) and entry.claim is None
        claim_function = None if plain_offset else self._claim(claim).state
        return SpooferBroadcaster(
            serial,
            offset if offset is not None else (0.0, 0.0, 0.0),
            scenario.origin,
            scenario.start_unix_s,
            ground,
            phase_s=phase,
            claim=claim_function,
            silent_intervals_s=entry.silent_intervals_s,
        )

    def _claim(self, claim: ClaimConfig) -> Claim:
        target = None
        if claim.kind == "mimic":
            assert claim.target_serial is not None
            index = self._index_of_serial(claim.target_serial)
            target = self.histories.setdefault(index, TrackHistory())
        return Claim(claim, target)

    def _power(self, serial: str, config: TxPowerConfig | None) -> TxPowerDraw | None:
        if config is None or config.kind == "fixed":
            return None  # the channel's per-vehicle power (Scenario.tx_power_dbm_of)
        return TxPowerDraw(config, rng.stream(self.scenario.seed, f"sim/tx-power/{serial}"))

    def initial_state(self, index: int) -> tuple[FloatArray, FloatArray, float]:
        """(position, velocity, heading rad) of adversary vehicle ``index`` at t = 0."""
        n = len(self.scenario.aircraft)
        spoofers = self.scenario.all_spoofers
        if index < n + len(spoofers):
            spoofer = spoofers[index - n]
            motion = spoofer.resolved_motion
            if spoofer.motion is None:  # the shorthand line, as it always started
                assert spoofer.start_enu_m is not None and spoofer.goal_enu_m is not None
                delta = np.subtract(spoofer.goal_enu_m, spoofer.start_enu_m)
                norm = float(np.linalg.norm(delta))
                v = spoofer.speed_m_s * delta / norm if norm > 0 else np.zeros(3)
                return np.array(spoofer.start_enu_m), v, math.atan2(delta[1], delta[0])
            p0 = np.array(motion.initial_enu_m, dtype=np.float64)
            if motion.kind == "pursue":
                return p0, np.zeros(3), 0.0
            _, v0 = self.mission(index).target(0.0)
            return p0, v0, math.atan2(v0[1], v0[0]) if np.any(v0[:2]) else 0.0
        ghost = self.scenario.ghosts[index - n - len(spoofers)]
        return np.array(ghost.transmitter_enu_m, dtype=np.float64), np.zeros(3), 0.0

    def mission(self, index: int) -> Mission:
        """The autopilot mission of adversary vehicle ``index`` (a ghost: hold its place)."""
        n = len(self.scenario.aircraft)
        spoofers = self.scenario.all_spoofers
        if index >= n + len(spoofers):
            t = self.scenario.ghosts[index - n - len(spoofers)].transmitter_enu_m
            return StraightLineMission(t, t, 1.0)
        motion = spoofers[index - n].resolved_motion

        def own() -> FloatArray:
            return self.position_of(index)

        target = None
        if motion.target_serial is not None:
            j = self._index_of_serial(motion.target_serial)

            def target_position() -> FloatArray:
                return self.position_of(j)

            target = target_position
        return make_mission(motion, own, target)

    # -- every tick -----------------------------------------------------------------------

    def record(self, now_s: float, p_enu_m: FloatArray, v_enu_m_s: FloatArray) -> None:
        """Record the true state of the mimicked aircraft (rows of the fleet state)."""
        for index, history in self.histories.items():
            history.record(now_s, p_enu_m[index], v_enu_m_s[index])

    @property
    def has_silences(self) -> bool:
        return any(a.broadcaster.silent_intervals_s for a in self.items)

    def silent(self, index: int, now_s: float) -> bool:
        """Vehicle ``index`` is an adversary in one of its silent windows."""
        adversary = self.by_index.get(index)
        return adversary is not None and silent_at(adversary.broadcaster.silent_intervals_s, now_s)

    @property
    def has_random_power(self) -> bool:
        return any(a.power is not None for a in self.items)

    def power_dbm(self, index: int) -> float | None:
        """A fresh power for the next message of vehicle ``index`` (None: fixed power)."""
        adversary = self.by_index.get(index)
        if adversary is None or adversary.power is None:
            return None
        adversary.last_tx_power_dbm = adversary.power.next_dbm()
        return adversary.last_tx_power_dbm

    def truth_record(
        self, now_s: float, p_enu_m: FloatArray, v_enu_m_s: FloatArray
    ) -> list[dict[str, object]]:
        """Per adversary: sysid, serial, role, claimed state, silent now, last random power."""
        out: list[dict[str, object]] = []
        for a in self.items:
            claimed, claimed_v = a.broadcaster.claimed_state(
                now_s, p_enu_m[a.index], v_enu_m_s[a.index]
            )
            silent = silent_at(a.broadcaster.silent_intervals_s, now_s)
            out.append(
                {
                    "sysid": a.index + 1,
                    "serial": a.serial,
                    "role": a.role.value,
                    "claimed_p_enu_m": np.round(claimed, 4).tolist(),
                    "claimed_v_enu_m_s": np.round(claimed_v, 4).tolist(),
                    "silent": silent,
                    "tx_power_dbm": a.last_tx_power_dbm,
                }
            )
        return out
