"""The one factory of a run's cores: a scenario file in, a sim backend, companions and a GCS out.

Every way of running builds its cores here, one function per app: the lockstep runner (all
cores in one process, :mod:`ridsafe.tools.run.lockstep`) and the standalone commands
(``ridsafe sim``, ``ridsafe gcs``, ``ridsafe companion``: one app per process), which is also
what a live run starts (:mod:`ridsafe.tools.run.live`). So one scenario file gives the same
cores whichever way they run. What legitimately differs comes in as an argument: where the
records go (``sink``), the MAVLink signing of the GCS links, which sim endpoints exist (a
lockstep run has no GCS stream), and where the GCS takes its clock from (a live GCS may start
before or after its companions).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

from ridsafe.common import codec
from ridsafe.common.heard import RidFrameDecoder
from ridsafe.common.logsink import LogSink
from ridsafe.companion.companion import Companion
from ridsafe.companion.config import CompanionSpec
from ridsafe.companion.planners import PlannerSettings, make_planner
from ridsafe.sim_backend.world import EndpointKind, SimBackend
from ridsafe.tools.run.scenario import ScenarioFile

# The GCS is imported where one is made: a companion's or the sim's process never loads it.
if TYPE_CHECKING:
    from ridsafe.gcs.config import ClockSource
    from ridsafe.gcs.gcs import Gcs
    from ridsafe.gcs.pipeline_api import GcsPipeline

__all__ = [
    "LOCKSTEP_SIM_ENDPOINTS",
    "companion_ids",
    "live_sim_endpoints",
    "make_companion",
    "make_companions",
    "make_estimation_pipeline",
    "make_gcs",
    "make_sim_backend",
    "planner_settings",
]

#: A lockstep run routes only the companions' links; nobody listens to a GCS stream.
LOCKSTEP_SIM_ENDPOINTS: tuple[EndpointKind, ...] = (EndpointKind.COMPANION,)


def live_sim_endpoints(loaded: ScenarioFile) -> tuple[EndpointKind, ...]:
    """A live sim's endpoints: each vehicle's companion port, and its GCS stream when
    ``sim.ports.gcs_out_enabled``."""
    if loaded.sim.ports.gcs_out_enabled:
        return (EndpointKind.COMPANION, EndpointKind.GCS)
    return (EndpointKind.COMPANION,)


def make_sim_backend(
    loaded: ScenarioFile,
    sink: LogSink,
    endpoints: Iterable[EndpointKind],
    autopilot_signing: codec.SigningConfig | None = None,
) -> SimBackend:
    """The sim backend of the scenario (every vehicle, the spoofer included);
    ``autopilot_signing`` signs its companion ports (``run.sign_autopilot_links``)."""
    return SimBackend(
        loaded.scenario,
        loaded.sim,
        tuple(endpoints),
        sink=sink,
        companion_signing=autopilot_signing,
    )


def companion_ids(loaded: ScenarioFile) -> Sequence[int]:
    """System ids of the benign aircraft, each flown by one companion: 1..N."""
    return range(1, len(loaded.scenario.aircraft) + 1)


def planner_settings(loaded: ScenarioFile, sysid: int) -> PlannerSettings:
    """What the planner of aircraft ``sysid`` is built with (the ``companion`` and
    ``planner`` sections, the scenario seed)."""
    config = loaded.companion
    return PlannerSettings(
        sysid=sysid,
        cruise_speed_m_s=config.cruise_speed_m_s,
        replan_period_s=config.replan_period_s,
        lookahead_s=config.lookahead_s,
        approach_radius_m=config.approach_radius_m,
        arrival_radius_m=config.arrival_radius_m,
        seed=loaded.scenario.seed,
        config=loaded.planner,
    )


def make_companion(
    loaded: ScenarioFile,
    sysid: int,
    planner: str,
    sink: LogSink,
    signing: codec.SigningConfig | None,
    frame_decoder: RidFrameDecoder | None = None,
    autopilot_signing: codec.SigningConfig | None = None,
) -> Companion:
    """The companion of benign aircraft ``sysid`` flying with the named planner;
    ``frame_decoder`` is shared by the companions of one process (a broadcast that all of
    them hear is then decoded once); ``autopilot_signing`` signs its autopilot link."""
    spec = CompanionSpec.from_scenario(loaded.scenario, sysid, loaded.companion.operator_id)
    chosen = make_planner(planner, planner_settings(loaded, sysid))
    return Companion(
        spec,
        loaded.companion,
        chosen,
        sink,
        signing,
        frame_decoder=frame_decoder,
        autopilot_signing=autopilot_signing,
    )


def make_companions(
    loaded: ScenarioFile,
    sysids: Iterable[int],
    planner: str,
    sink: LogSink,
    signing: codec.SigningConfig | None,
    autopilot_signing: codec.SigningConfig | None = None,
) -> dict[int, Companion]:
    """:func:`make_companion` for each of ``sysids``, by system id (in the given order),
    sharing one RID frame decoder."""
    decoder = RidFrameDecoder()
    return {
        sysid: make_companion(loaded, sysid, planner, sink, signing, decoder, autopilot_signing)
        for sysid in sysids
    }


def make_estimation_pipeline(loaded: ScenarioFile) -> GcsPipeline:
    """The GCS's estimation pipeline, configured by the file's ``pipeline`` section."""
    from ridsafe.gcs.calibration.pipeline import make_pipeline  # noqa: PLC0415 (see above)

    return make_pipeline(loaded.pipeline)


def make_gcs(
    loaded: ScenarioFile,
    sink: LogSink,
    signing: codec.SigningConfig | None,
    clock: ClockSource | None = None,
) -> Gcs:
    """The GCS of the scenario; ``clock`` replaces ``gcs.clock`` when given."""
    from ridsafe.gcs.gcs import Gcs  # noqa: PLC0415 (see the imports)

    config = loaded.gcs if clock is None else dataclasses.replace(loaded.gcs, clock=clock)
    pipeline = make_estimation_pipeline(loaded)
    return Gcs(config, loaded.scenario.origin, pipeline, sink, signing)
