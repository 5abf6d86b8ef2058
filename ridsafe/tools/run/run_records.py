"""What a run's log says about the run itself: the ``/run/meta`` and ``/run/end`` records.

Written by the runner (lockstep, or the supervisor of a live run), read by the metrics
(``ridsafe.tools.analysis.run_arrays``): which aircraft are benign, their goals, the spoofer,
the NMAC threshold, the whole scenario file, and how the run ended.
"""

from __future__ import annotations

import math
import time

from ridsafe import __version__
from ridsafe.common import topics
from ridsafe.common.adversary import AdversaryRole
from ridsafe.common.config import to_mapping
from ridsafe.common.logsink import LogSink
from ridsafe.tools.run.scenario import ScenarioFile

__all__ = ["NMAC_THRESHOLD_M", "adversaries", "log_meta", "run_end", "run_meta"]

NMAC_THRESHOLD_M = 50.0


def run_meta(loaded: ScenarioFile, mode: str, planner: str) -> dict[str, object]:
    """The ``/run/meta`` record (topics.py): everything metrics need to know of the run."""
    scenario = loaded.scenario
    spoofer = None
    # the first spoofer that lies (every one, bystanders too: ``adversaries``)
    liars = (k for k, s in enumerate(scenario.all_spoofers) if s.role is AdversaryRole.SPOOFER)
    k = next(liars, None)
    if k is not None:
        first = scenario.all_spoofers[k]
        claim = first.resolved_claim
        spoofer = {
            "sysid": scenario.first_spoofer_sysid + k,
            "serial": first.serial,
            "offset_enu_m": None if claim.offset_enu_m is None else list(claim.offset_enu_m),
        }
    return {
        "mode": mode,
        "seed": scenario.seed,
        "planner": planner,
        "version": __version__,
        "started_unix_s": time.time(),
        "scenario": to_mapping(loaded),
        "aircraft": [
            {
                "sysid": k + 1,
                "serial": a.serial,
                "start_enu_m": list(a.start_enu_m),
                "goal_enu_m": list(a.goal_enu_m),
                "cruise_alt_m": a.cruise_alt_m,
            }
            for k, a in enumerate(scenario.aircraft)
        ],
        "spoofer": spoofer,
        "adversaries": adversaries(loaded),
        "nmac_threshold_m": NMAC_THRESHOLD_M,
    }


def adversaries(loaded: ScenarioFile) -> list[dict[str, object]]:
    """Every spoofer, bystander and ghost: sysid, serial, role ("spoofer" / "bystander" /
    "ghost") and the kinds of its motion, claim and power (the metrics' per-adversary keys
    read this)."""
    scenario = loaded.scenario
    out: list[dict[str, object]] = []
    for k, spoofer in enumerate(scenario.all_spoofers):
        power = spoofer.tx_power
        out.append(
            {
                "sysid": scenario.first_spoofer_sysid + k,
                "serial": spoofer.serial,
                "role": spoofer.role.value,
                "motion": spoofer.resolved_motion.kind,
                "claim": spoofer.resolved_claim.kind,
                "tx_power": "fixed" if power is None else power.kind,
            }
        )
    for k, ghost in enumerate(scenario.ghosts):
        out.append(
            {
                "sysid": scenario.first_ghost_sysid + k,
                "serial": ghost.serial,
                "role": AdversaryRole.GHOST.value,
                "transmitter_enu_m": list(ghost.transmitter_enu_m),
                "claim": ghost.claim.kind,
                "tx_power": "fixed" if ghost.tx_power is None else ghost.tx_power.kind,
            }
        )
    return out


def run_end(wall_clock_s: float, sim_time_s: float, status: str, reason: str) -> dict[str, object]:
    """The ``/run/end`` record: how long the run took and how it ended."""
    return {
        "wall_clock_s": wall_clock_s,
        "sim_time_s": sim_time_s if math.isfinite(sim_time_s) else None,
        "status": status,
        "reason": reason,
    }


def log_meta(sink: LogSink, meta: dict[str, object]) -> None:
    sink.log(topics.RUN_META, 0.0, meta)
