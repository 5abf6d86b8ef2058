"""One scenario file: the shared world plus every app's own section.

```yaml
scenario: {...}   # ridsafe.common.scenario.Scenario: origin, aircraft, spoofer, radio, seed
sim: {...}        # ridsafe.sim_backend.config.SimConfig: vehicle, controller, rates, ports
companion: {...}  # ridsafe.companion.config.CompanionConfig: streams, take-off, RID, loops
planner: {...}    # ridsafe.companion.planner_config.PlannerConfig: rewards, actions, horizon
gcs: {...}        # ridsafe.gcs.config.GcsConfig: cycle, ingest limits, peers
pipeline: {...}   # ridsafe.gcs.pipeline_config.PipelineConfig: detection, localisation, IMM
run: {...}        # RunConfig: planner name, ticks, signing, ports of a live run
family: {...}     # optional: ridsafe.tools.run.scenario_family.FamilyConfig, to draw scenarios
sweep: {...}      # optional: ridsafe.tools.sweep.config.SweepConfig, the experiment matrix
```

Every section is optional except ``scenario``; missing sections take their defaults.

``load_scenario_file`` reads and validates it (unknown keys and wrong types fail before
anything starts, naming file and key path); ``rescale_aircraft`` changes the benign traffic
for ``--vehicles`` / ``--aircraft``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from ridsafe.common.config import OVERRIDE_SOURCE, load_config, with_overrides
from ridsafe.common.errors import ConfigError, ConnectionStringError, FieldValueError
from ridsafe.common.scenario import Scenario, cta2063_serial
from ridsafe.common.udp import parse_connection_string
from ridsafe.companion.config import CompanionConfig
from ridsafe.companion.planner_config import PlannerConfig
from ridsafe.gcs.config import GcsConfig
from ridsafe.gcs.pipeline_config import PipelineConfig
from ridsafe.sim_backend.config import SimConfig
from ridsafe.tools.run.depotcity import DepotCityConfig, apply_depotcity
from ridsafe.tools.run.scenario_family import FamilyConfig, generate
from ridsafe.tools.sweep.config import SweepConfig

REPO_ROOT = Path(__file__).resolve().parents[3]
DEFAULT_SCENARIO = Path("configs") / "default.yaml"
SERIAL_MAKER_CODE = "RSAF"
SPREAD_M = 15.0  # spacing of extra aircraft sharing a depot
LAUNCH_INTERVAL_S = 8.0  # extra aircraft at one depot depart this long after each other


@dataclass(frozen=True)
class RunConfig:
    """How ``ridsafe run`` runs a scenario."""

    planner: str = "aware"
    # Lockstep: bytes cross between the cores every tick (the sim integrates at 400 Hz and
    # controls at 100 Hz inside a tick). 50 ms divides every period the apps keep (GCS cycle
    # 0.25 s, planner 0.5 s, telemetry 0.2 s, RID 1 s) and costs little fidelity.
    lockstep_tick_s: float = 0.05
    live_tick_s: float = 0.01
    sign_gcs_links: bool = True  # MAVLink 2 signing between companions and the GCS
    # MAVLink 2 signing between each companion and its autopilot (the sim's companion port),
    # as ArduPilot offers with a key set; off by default, as on most real aircraft.
    sign_autopilot_links: bool = False
    gcs_listen: str = "udpin:127.0.0.1:14450"
    # Where a live run's companions send to the GCS (udpout:HOST:PORT); empty: to
    # gcs_listen's address. Something else in between (a relay, a radio bridge) listens here.
    gcs_connect: str = ""
    # The log's derived Foxglove channels (3D scene of the aircraft and regions, map fixes),
    # next to the records: about half of a log's bytes. A sweep leaves them out by default.
    foxglove_channels: bool = True

    def __post_init__(self) -> None:
        for name in ("lockstep_tick_s", "live_tick_s"):
            if not 0.001 <= getattr(self, name) <= 0.1:
                raise FieldValueError(name, f"expected 0.001..0.1 s, got {getattr(self, name)}")
        _check_connection("gcs_listen", self.gcs_listen, listens=True)
        if self.gcs_connect:
            _check_connection("gcs_connect", self.gcs_connect, listens=False)


def _check_connection(name: str, text: str, listens: bool) -> None:
    try:
        spec = parse_connection_string(text)
    except ConnectionStringError as exc:
        raise FieldValueError(name, str(exc)) from None
    if spec.mode.listens is not listens:
        expected = "udpin" if listens else "udpout"
        raise FieldValueError(name, f"expected {expected}:HOST:PORT, got {text!r}")


@dataclass(frozen=True)
class ScenarioFile:
    scenario: Scenario
    sim: SimConfig = field(default_factory=SimConfig)
    companion: CompanionConfig = field(default_factory=CompanionConfig)
    planner: PlannerConfig = field(default_factory=PlannerConfig)
    gcs: GcsConfig = field(default_factory=GcsConfig)
    pipeline: PipelineConfig = field(default_factory=PipelineConfig)
    run: RunConfig = field(default_factory=RunConfig)
    family: FamilyConfig | None = None
    # The authors' per-seed goal reassignment and per-N spoofer offset (tools/run/depotcity.py).
    depotcity: DepotCityConfig | None = None
    sweep: SweepConfig | None = None  # the experiment matrix of ``ridsafe sweep``


def resolve_config_path(path: str | Path | None) -> Path:
    """The given path, or ``configs/default.yaml`` (here, else in the source checkout)."""
    if path is not None:
        return Path(path)
    if DEFAULT_SCENARIO.exists():
        return DEFAULT_SCENARIO
    return REPO_ROOT / DEFAULT_SCENARIO


def load_scenario_file(
    path: str | Path | None = None, overrides: Mapping[str, object] | None = None
) -> ScenarioFile:
    loaded = load_config(resolve_config_path(path), ScenarioFile)
    return with_overrides(loaded, overrides) if overrides else loaded


def rescale_aircraft(scenario: Scenario, count: int) -> Scenario:
    """``count`` benign aircraft: the first ``count`` configured, or all of them plus extra
    ones that wait their turn at the same depots (``SPREAD_M`` apart, each round departing
    ``LAUNCH_INTERVAL_S`` after the previous one) and deliver to the configured sites in a
    rotated order, ``SPREAD_M`` further out per round."""
    if count < 1:
        raise ValueError(f"need at least one aircraft, got {count}")
    base = scenario.aircraft
    if not base:
        raise ValueError("the scenario has no aircraft to rescale")
    aircraft = list(base[:count])
    for k in range(len(base), count):
        template, rnd = base[k % len(base)], k // len(base)
        goal = base[(k + rnd) % len(base)].goal_enu_m
        aircraft.append(
            dataclasses.replace(
                template,
                serial=cta2063_serial(SERIAL_MAKER_CODE, f"{k + 1:08d}"),
                start_enu_m=_shifted(template.start_enu_m, SPREAD_M * rnd),
                goal_enu_m=_shifted(goal, SPREAD_M * rnd),
                departure_s=template.departure_s + LAUNCH_INTERVAL_S * rnd,
            )
        )
    return dataclasses.replace(scenario, aircraft=tuple(aircraft))


#: Scenario keys a family draws anew: overrides under them are re-applied to the drawn scenario.
FAMILY_DRAWN_KEYS = ("scenario.spoofer", "scenario.spoofers", "scenario.ghosts")


def with_aircraft(
    loaded: ScenarioFile, count: int, overrides: Mapping[str, object] | None = None
) -> ScenarioFile:
    """The file with ``count`` benign aircraft: drawn from its ``family`` when it has one,
    else by ``rescale_aircraft``.

    ``overrides`` are the command line's ``--set`` values (already applied to ``loaded``). A
    family draws the aircraft and the adversaries anew, so the overrides under
    ``FAMILY_DRAWN_KEYS`` are applied again to the drawn scenario (an error if they do not fit
    it, e.g. ``scenario.spoofer.*`` when the family drew a list of spoofers), and an override
    of ``scenario.aircraft`` is an error: never silently dropped."""
    scenario = loaded.scenario
    if loaded.family is None:
        scenario = rescale_aircraft(scenario, count)
        if loaded.depotcity is not None:
            scenario = apply_depotcity(scenario, loaded.depotcity)
        return dataclasses.replace(loaded, scenario=scenario)
    scenario = generate(scenario, count, scenario.seed, loaded.family)
    drawn = {k: v for k, v in (overrides or {}).items() if _under(k, FAMILY_DRAWN_KEYS)}
    for key in overrides or {}:
        if _under(key, ("scenario.aircraft",)):
            raise ConfigError(
                OVERRIDE_SOURCE,
                key,
                "the family draws the aircraft for --aircraft: this override cannot apply "
                "(set the family's keys instead)",
            )
    if drawn:
        names = sorted({k.split(".")[1] for k in drawn})
        for name in names:
            if name == "spoofer" and scenario.spoofer is None:
                raise ConfigError(
                    OVERRIDE_SOURCE,
                    "scenario.spoofer",
                    "the family drew its spoofers into scenario.spoofers, not the single "
                    "scenario.spoofer: set family.adversaries keys instead",
                )
        relative = {k.removeprefix("scenario."): v for k, v in drawn.items()}
        scenario = with_overrides(scenario, relative)
    return dataclasses.replace(loaded, scenario=scenario)


def check_no_drawn_overrides(loaded: ScenarioFile, overrides: Mapping[str, object]) -> None:
    """A sweep draws every run's aircraft and adversaries from the family: a ``--set`` under
    ``scenario.aircraft`` or ``FAMILY_DRAWN_KEYS`` would be lost, so it is an error."""
    if loaded.family is None:
        return
    for key in overrides:
        if _under(key, ("scenario.aircraft", *FAMILY_DRAWN_KEYS)):
            raise ConfigError(
                OVERRIDE_SOURCE,
                key,
                "every run's aircraft and adversaries are drawn from the family: set "
                "family.* keys (e.g. family.adversaries.tx_power_dbm) instead",
            )


def _under(key: str, prefixes: tuple[str, ...]) -> bool:
    return any(key == p or key.startswith(p + ".") for p in prefixes)


def _shifted(p: tuple[float, float, float], dx_m: float) -> tuple[float, float, float]:
    return (p[0] + dx_m, p[1], p[2])
