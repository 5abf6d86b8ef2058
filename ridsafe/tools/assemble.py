"""Building one run's cores from a scenario file, and what the run log says about it.

Shared by the lockstep runner (all cores in one process) and the live commands (one app per
process), so both run the same components with the same settings.
"""

from __future__ import annotations

import hashlib
import math
import time
from collections.abc import Sequence

from ridsafe import __version__
from ridsafe.common import codec, topics
from ridsafe.common.config import to_mapping
from ridsafe.common.heard import RidFrameDecoder
from ridsafe.common.logsink import LogSink
from ridsafe.companion.companion import Companion
from ridsafe.companion.config import CompanionSpec
from ridsafe.companion.planners import PlannerSettings, make_planner
from ridsafe.gcs.gcs import Gcs
from ridsafe.gcs.pipeline import EstimationPipeline
from ridsafe.sim_backend.world import EndpointKind, SimBackend
from ridsafe.tools.scenario import ScenarioFile

NMAC_THRESHOLD_M = 50.0


def signing_for_lockstep(loaded: ScenarioFile) -> codec.SigningConfig | None:
    """A key derived from the seed (a lockstep run must be bit-reproducible; it never leaves
    the process) and a fixed first timestamp."""
    if not loaded.run.sign_gcs_links:
        return None
    key = hashlib.sha256(f"ridsafe-lockstep-{loaded.scenario.seed}".encode()).digest()
    return codec.SigningConfig(key, codec.signing_timestamp_from_unix(loaded.scenario.start_unix_s))


def make_sim(loaded: ScenarioFile, sink: LogSink, gcs_streams: bool = False) -> SimBackend:
    kinds = [EndpointKind.COMPANION] + ([EndpointKind.GCS] if gcs_streams else [])
    return SimBackend(loaded.scenario, loaded.sim, kinds, sink=sink)


def make_companion(
    loaded: ScenarioFile,
    sysid: int,
    planner: str,
    sink: LogSink,
    signing: codec.SigningConfig | None,
    frame_decoder: RidFrameDecoder | None = None,
) -> Companion:
    """``frame_decoder``: share one between the companions of a process (a broadcast that
    all of them hear is then decoded once)."""
    config = loaded.companion
    spec = CompanionSpec.from_scenario(loaded.scenario, sysid, config.operator_id)
    settings = PlannerSettings(
        sysid=sysid,
        cruise_speed_m_s=config.cruise_speed_m_s,
        replan_period_s=config.replan_period_s,
        lookahead_s=config.lookahead_s,
        approach_radius_m=config.approach_radius_m,
        arrival_radius_m=config.arrival_radius_m,
        seed=loaded.scenario.seed,
        config=loaded.planner,
    )
    planner_core = make_planner(planner, settings)
    return Companion(spec, config, planner_core, sink, signing, frame_decoder=frame_decoder)


def make_gcs(loaded: ScenarioFile, sink: LogSink, signing: codec.SigningConfig | None) -> Gcs:
    pipeline = EstimationPipeline(loaded.pipeline)
    return Gcs(loaded.gcs, loaded.scenario.origin, pipeline, sink, signing)


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
    return {
        "wall_clock_s": wall_clock_s,
        "sim_time_s": sim_time_s if math.isfinite(sim_time_s) else None,
        "status": status,
        "reason": reason,
    }


def log_meta(sink: LogSink, meta: dict[str, object]) -> None:
    sink.log(topics.RUN_META, 0.0, meta)


def companion_ids(loaded: ScenarioFile) -> Sequence[int]:
    return range(1, len(loaded.scenario.aircraft) + 1)
