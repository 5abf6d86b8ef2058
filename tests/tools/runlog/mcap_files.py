"""Run-log files for the tests: real MCAP files written by the recorder, read back with the
``mcap`` library's own reader (:func:`raw_messages`), and the records a run logs."""

from __future__ import annotations

import json
import math
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from mcap.reader import make_reader
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from ridsafe.common import topics
from ridsafe.tools.runlog.writer import McapRecorder

FloatArray = NDArray[np.float64]
ORIGIN = {"lat_deg": 36.1447, "lon_deg": -86.8027, "alt_m": 180.0}
CHI2_95 = 7.814727903251178


def cycle(k: int) -> dict[str, Any]:
    return {"compute_ms": 0.5 + k, "n_observations": k, "n_transmissions": 2, "n_tracks": 1}


def raw_messages(path: Path) -> list[dict[str, Any]]:
    """Every message of a complete file, read with the mcap library's own (seeking) reader."""
    out = []
    with open(path, "rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages(log_time_order=False):
            out.append(
                {
                    "topic": channel.topic,
                    "message_encoding": channel.message_encoding,
                    "schema_name": schema.name if schema else None,
                    "schema_encoding": schema.encoding if schema else None,
                    "schema": json.loads(schema.data) if schema else None,
                    "log_time": message.log_time,
                    "publish_time": message.publish_time,
                    "data": json.loads(message.data, parse_constant=_reject_constant),
                }
            )
    return out


def _reject_constant(name: str) -> Any:
    raise AssertionError(f"invalid JSON constant {name} in the log")


def write_cycles(path: Path, count: int, **options: Any) -> list[tuple[str, float, Any]]:
    logged = []
    with McapRecorder(path, **options) as recorder:
        for k in range(count):
            t_s = 0.25 * k
            recorder.log(topics.GCS_CYCLE, t_s, cycle(k))
            logged.append((topics.GCS_CYCLE, t_s, {"t_s": t_s, **cycle(k)}))
    return logged


def truncated_copy(path: Path, out: Path, size: int) -> Path:
    shutil.copyfile(path, out)
    with open(out, "r+b") as stream:
        stream.truncate(size)
    return out


def meta_record() -> dict[str, Any]:
    return {
        "mode": "lockstep",
        "seed": 1,
        "planner": "spoofing_aware",
        "scenario": {"scenario": {"origin": ORIGIN}},
        "aircraft": [],
        "spoofer": None,
        "nmac_threshold_m": 50.0,
        "adversaries": [],
    }


def truth_record(t_s: float) -> dict[str, Any]:
    return {
        "sysid": [1, 2, 3],
        "p_enu_m": [[10.0 * t_s, 0.0, 60.0], [0.0, 100.0, 50.0], [-200.0 + 7 * t_s, 5.0, 60.0]],
        "v_enu_m_s": [[10.0, 0.0, 0.0], [0.0, 0.0, 0.0], [7.0, 0.0, 0.0]],
        "armed": [True, True, True],
        "mode": [4, 4, 4],
        "spoofer_sysid": 3,
        "spoofer_claimed_p_enu_m": [-150.0 + 7 * t_s, 55.0, 60.0],
        "adversaries": [],
    }


def rotated_cov() -> FloatArray:
    rotation = Rotation.from_euler("zyx", [35.0, -20.0, 50.0], degrees=True).as_matrix()
    return np.asarray(rotation @ np.diag([900.0, 100.0, 2500.0]) @ rotation.T)


def region_record(cov: FloatArray) -> dict[str, Any]:
    return {
        "uas_id": "RSAF800000666",
        "track_id": 7,
        "center_enu_m": [-190.0, 10.0, 55.0],
        "cov_enu_m2": cov.tolist(),
        "chi2_threshold": CHI2_95,
        "alpha": 0.05,
        "valid_until_s": 2.0,
        "semi_axes_m": [0.0, 0.0, 0.0],
    }


def by_topic(messages: list[dict[str, Any]]) -> dict[str, list[dict[str, Any]]]:
    grouped: dict[str, list[dict[str, Any]]] = {}
    for m in messages:
        grouped.setdefault(m["topic"], []).append(m)
    return grouped


def check_schema(value: Any, schema: Mapping[str, Any], where: str) -> None:
    """The subset of JSON Schema the Foxglove schemas use: type, properties, required,
    items, minimum / maximum, minItems / maxItems (written here, independent of the writer)."""
    kind = schema.get("type")
    python_types: dict[str, type | tuple[type, ...]] = {
        "object": dict, "array": list, "string": str, "boolean": bool,
        "integer": int, "number": (int, float),
    }  # fmt: skip
    if kind is not None:
        assert isinstance(value, python_types[kind]), f"{where}: {value!r} is no {kind}"
        assert kind in ("boolean",) or not isinstance(value, bool), f"{where}: a bool"
    if kind == "object":
        for name in schema.get("required", ()):
            assert name in value, f"{where}: missing {name}"
        for name, sub in schema.get("properties", {}).items():
            if name in value:
                check_schema(value[name], sub, f"{where}.{name}")
    if kind == "array":
        assert schema.get("minItems", 0) <= len(value) <= schema.get("maxItems", math.inf)
        for k, item in enumerate(value):
            check_schema(item, schema.get("items", {}), f"{where}[{k}]")
    if kind in ("number", "integer"):
        assert schema.get("minimum", -math.inf) <= value <= schema.get("maximum", math.inf)
