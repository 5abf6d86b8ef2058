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
from ridsafe.common.config import to_mapping
from ridsafe.common.logsink import LogSink
from ridsafe.tools.run.scenario import ScenarioFile

__all__ = ["NMAC_THRESHOLD_M", "log_meta", "run_end", "run_meta"]

NMAC_THRESHOLD_M = 50.0


def run_meta(loaded: ScenarioFile, mode: str, planner: str) -> dict[str, object]:
    """The ``/run/meta`` record (topics.py): everything metrics need to know of the run."""
    scenario = loaded.scenario
    n = len(scenario.aircraft)
    spoofer = None
    if scenario.spoofer is not None:
        spoofer = {
            "sysid": n + 1,
            "serial": scenario.spoofer.serial,
            "offset_enu_m": list(scenario.spoofer.offset_enu_m),
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
        "nmac_threshold_m": NMAC_THRESHOLD_M,
    }


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
