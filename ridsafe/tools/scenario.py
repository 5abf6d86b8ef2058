"""One scenario file: the shared world plus every app's own section.

```yaml
scenario: {...}   # ridsafe.common.scenario.Scenario: origin, aircraft, spoofer, radio, seed
sim: {...}        # ridsafe.sim_backend.config.SimConfig: vehicle, controller, rates, ports
```

``load_scenario_file`` reads and validates it (unknown keys and wrong types fail before
anything starts, naming file and key path); ``rescale_aircraft`` changes the benign traffic
for ``--vehicles`` / ``--aircraft``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

from ridsafe.common.config import load_config, with_overrides
from ridsafe.common.scenario import Scenario, cta2063_serial
from ridsafe.sim_backend.config import SimConfig

REPO_ROOT = Path(__file__).resolve().parents[2]
DEFAULT_SCENARIO = Path("configs") / "default.yaml"
SERIAL_MAKER_CODE = "RSAF"
SPREAD_M = 15.0  # spacing of extra aircraft sharing a depot


@dataclass(frozen=True)
class ScenarioFile:
    scenario: Scenario
    sim: SimConfig = field(default_factory=SimConfig)


def resolve_config_path(path: str | Path | None) -> Path:
    """The given path, or ``configs/default.yaml`` (here, else in the source checkout)."""
    if path is not None:
        return Path(path)
    if DEFAULT_SCENARIO.exists():
        return DEFAULT_SCENARIO
    return REPO_ROOT / DEFAULT_SCENARIO


def load_scenario_file(
    path: str | Path | None = None, overrides: dict[str, object] | None = None
) -> ScenarioFile:
    loaded = load_config(resolve_config_path(path), ScenarioFile)
    return with_overrides(loaded, overrides) if overrides else loaded


def rescale_aircraft(scenario: Scenario, count: int) -> Scenario:
    """``count`` benign aircraft: the first ``count`` configured, or all of them cycled with
    the extra ones placed ``SPREAD_M`` apart at the same depots and delivery sites."""
    if count < 1:
        raise ValueError(f"need at least one aircraft, got {count}")
    base = scenario.aircraft
    if not base:
        raise ValueError("the scenario has no aircraft to rescale")
    aircraft = []
    for k in range(count):
        template = base[k % len(base)]
        if k < len(base):
            aircraft.append(template)
            continue
        shift = SPREAD_M * (k // len(base))
        aircraft.append(
            dataclasses.replace(
                template,
                serial=cta2063_serial(SERIAL_MAKER_CODE, f"{k + 1:08d}"),
                start_enu_m=_shifted(template.start_enu_m, shift),
                goal_enu_m=_shifted(template.goal_enu_m, shift),
            )
        )
    return dataclasses.replace(scenario, aircraft=tuple(aircraft))


def _shifted(p: tuple[float, float, float], dx_m: float) -> tuple[float, float, float]:
    return (p[0] + dx_m, p[1], p[2])
