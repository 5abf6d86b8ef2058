"""The sweep's matrix as configuration: the YAML ``sweep:`` section and ``ridsafe sweep``'s flags.

```yaml
sweep:                          # every key optional; defaults: the paper's matrix
  densities: [4, 8, 12, 16]     # benign aircraft
  seeds: "0:30"                 # or a list; matched: every density and planner flies each
  planners: [aware, trust-rid]
  duration_s: 120.0             # default: the scenario's
  params:                       # extra axes, by name (run folder: .../{name}={value})
    rssi:
      keys: [scenario.radio.shadowing_sigma_db, pipeline.rssi_sigma_db]
      values: [1.0, 2.0]
  foxglove_channels: false      # the logs' derived Foxglove views (--foxglove)
```

A leaf module (only ``ridsafe.common`` and the planner registry), so the scenario file's
loader could hold a ``sweep:`` section without an import cycle.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from ridsafe.common.errors import FieldValueError
from ridsafe.companion.planners import PLANNERS

__all__ = ["ParamAxis", "ParamValue", "SweepConfig", "format_value", "parse_seeds"]

ParamValue = bool | int | float | str

#: Keys a parameter axis may not set: the matrix's own axes and what the family draws.
_RESERVED_KEYS = ("scenario.seed", "scenario.duration_s", "scenario.aircraft", "scenario.spoofer")
_NAME_RE = re.compile(r"^[A-Za-z][A-Za-z0-9_.-]*$")
_VALUE_RE = re.compile(r"^[A-Za-z0-9_.+-]+$")


def parse_seeds(text: str) -> tuple[int, ...]:
    """``"0:30"`` (start:stop, stop excluded), ``"0,3,7"`` or both: ``"0:10,20:25"``."""
    seeds: list[int] = []
    for part in text.replace(" ", "").split(","):
        start, sep, stop = part.partition(":")
        try:
            seeds.extend(range(int(start), int(stop)) if sep else [int(part)])
        except ValueError:
            raise ValueError(f"expected seeds like 0:30 or 0,1,5, got {text!r}") from None
    if not seeds or min(seeds) < 0 or len(set(seeds)) != len(seeds):
        raise ValueError(f"expected distinct non-negative seeds, got {text!r}")
    return tuple(seeds)


def format_value(value: ParamValue) -> str:
    """A parameter value as it appears in a run directory name."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value) if isinstance(value, float) else str(value)


@dataclass(frozen=True)
class ParamAxis:
    """One extra axis of the matrix: each value is set at every key (dotted override keys;
    several keys for settings that must move together, e.g. the radio's shadowing and the
    pipeline's assumed ``rssi_sigma_db``)."""

    keys: tuple[str, ...]
    values: tuple[ParamValue, ...]

    def __post_init__(self) -> None:
        if not self.keys:
            raise FieldValueError("keys", "expected at least one dotted key")
        for i, key in enumerate(self.keys):
            if key.startswith(_RESERVED_KEYS):
                raise FieldValueError(f"keys[{i}]", f"{key} is an axis of the sweep itself")
        if not self.values:
            raise FieldValueError("values", "expected at least one value")
        names = [format_value(v) for v in self.values]
        for i, name in enumerate(names):
            if not _VALUE_RE.match(name) or names.index(name) != i:
                raise FieldValueError(f"values[{i}]", f"not a distinct, path-safe value: {name!r}")


@dataclass(frozen=True)
class SweepConfig:
    """The matrix (YAML ``sweep:`` section; every key optional). Defaults: the paper's
    4 densities x 30 matched seeds x 2 planners at the scenario's duration."""

    densities: tuple[int, ...] = (4, 8, 12, 16)
    seeds: tuple[int, ...] | str = "0:30"  # a list, or "start:stop" / "0,1,5"
    planners: tuple[str, ...] = ("aware", "trust-rid")
    duration_s: float | None = None  # None: the scenario's ``duration_s``
    params: dict[str, ParamAxis] = field(default_factory=dict)  # axis name -> axis
    # Runs log every record their metrics and the report need; the derived Foxglove views
    # (``run.foxglove_channels``), about half of a log's bytes and ~5 % of its run time,
    # only when this is true.
    foxglove_channels: bool = False

    def __post_init__(self) -> None:
        _distinct("densities", self.densities)
        for i, n in enumerate(self.densities):
            if n < 1:
                raise FieldValueError(f"densities[{i}]", f"expected >= 1 aircraft, got {n}")
        try:
            self.seed_values  # noqa: B018 (validates)
        except ValueError as err:
            raise FieldValueError("seeds", str(err)) from err
        _distinct("planners", self.planners)
        for i, name in enumerate(self.planners):
            if name not in PLANNERS:
                known = ", ".join(sorted(PLANNERS))
                raise FieldValueError(f"planners[{i}]", f"unknown planner {name!r} ({known})")
        if self.duration_s is not None and not self.duration_s > 0.0:
            raise FieldValueError("duration_s", f"expected > 0 s, got {self.duration_s}")
        for name in self.params:
            if not _NAME_RE.match(name):
                raise FieldValueError(f"params.{name}", "axis names are letters, digits, _ . -")

    @property
    def seed_values(self) -> tuple[int, ...]:
        if isinstance(self.seeds, str):
            return parse_seeds(self.seeds)
        return parse_seeds(",".join(str(s) for s in self.seeds))


def _distinct(name: str, values: tuple[object, ...]) -> None:
    if not values:
        raise FieldValueError(name, "expected at least one value")
    if len(set(values)) != len(values):
        raise FieldValueError(name, f"expected distinct values, got {list(values)}")
