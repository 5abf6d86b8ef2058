"""A sweep's folder: where each run's log and result go, and what counts as finished.

The sweep folder DIR::

    DIR/sweep.json, scenario.yaml        manifest (config, matrix) and the base scenario file
    DIR/n{density}/{planner}/seed{seed:03d}[/{axis}={value}...]/
        run.mcap     the run log
        result.json  status (completed / interrupted / failed and why), spec, run digest,
                     metrics (:func:`run_metrics` of run.mcap, a cache), wall clock, worker
        run.log      the run's warnings (kept out of the progress bar)

Resume: a spec whose result.json says completed for the same run digest
(:func:`ridsafe.tools.sweep.plan.run_digest`, a fingerprint of the scenario it flies) is
finished (:func:`is_finished`), so running the same command again finishes a sweep, and after
a config edit flies again only what the edit changes.
"""

from __future__ import annotations

import enum
import json
import logging
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from ridsafe.common.config import to_mapping
from ridsafe.tools.sweep.plan import RunSpec, SweepError, SweepPlan

__all__ = [
    "LOG_FILE",
    "MANIFEST_FILE",
    "RESULT_FILE",
    "RUN_LOG_FILE",
    "SCENARIO_FILE",
    "RunOutcome",
    "RunStatus",
    "is_finished",
    "prepare_folder",
    "read_result",
    "record_outcome",
    "refresh_metrics",
    "run_metrics",
]

LOG_FILE = "run.mcap"
RESULT_FILE = "result.json"
RUN_LOG_FILE = "run.log"
MANIFEST_FILE = "sweep.json"
SCENARIO_FILE = "scenario.yaml"

Metrics = dict[str, float | int | None]

logger = logging.getLogger(__name__)


class RunStatus(enum.Enum):
    COMPLETED = "completed"
    INTERRUPTED = "interrupted"  # Ctrl-C during the run: the log is valid but short
    FAILED = "failed"  # raised, or its worker died: ``reason`` says why


def run_metrics(log_path: str | os.PathLike[str]) -> Metrics:
    """What a sweep records per run: the metrics of its log alone."""
    from ridsafe.tools.analysis.metrics import compute_metrics  # noqa: PLC0415

    return compute_metrics(log_path)


@dataclass(frozen=True)
class RunOutcome:
    """What a worker reports for one spec; ``log`` is the run.mcap when shipped back."""

    spec: RunSpec
    status: RunStatus
    reason: str
    metrics: Metrics
    wall_clock_s: float
    sim_time_s: float | None
    worker: str
    log_lines: tuple[str, ...] = ()
    log: bytes | None = field(default=None, repr=False)


def read_result(run_dir: Path) -> dict[str, Any] | None:
    """A run's result.json, or None when it has none (or an unreadable one)."""
    try:
        data = json.loads((run_dir / RESULT_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def refresh_metrics(run_dir: Path, metrics: Metrics) -> bool:
    """Rewrite the metrics cache of a run's result.json (and the size of the log they come
    from) after they were computed again; False, with a warning, when it cannot be (a folder
    not ours to write: the caller goes on with the metrics it has)."""
    result = read_result(run_dir)
    log = run_dir / LOG_FILE
    if result is None or not log.exists():
        return False
    result["metrics"] = metrics
    result["log_size_bytes"] = log.stat().st_size
    try:
        _write_atomic(run_dir / RESULT_FILE, (json.dumps(result, indent=2) + "\n").encode())
    except OSError as err:
        logger.warning("%s: metrics cache not updated: %s", run_dir / RESULT_FILE, err)
        return False
    return True


def is_finished(run_dir: Path, digest: str) -> bool:
    """Completed, for a scenario of this digest, and its log is there."""
    result = read_result(run_dir)
    return (
        bool(digest)
        and result is not None
        and result.get("status") == RunStatus.COMPLETED.value
        and result.get("run_digest") == digest
        and (run_dir / LOG_FILE).exists()
    )


def _write_atomic(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def record_outcome(out_dir: Path, plan: SweepPlan, outcome: RunOutcome, engine: str) -> Path:
    """Write the outcome's files (result.json last: it marks the run done)."""
    run_dir = out_dir / outcome.spec.run_dir
    run_dir.mkdir(parents=True, exist_ok=True)
    if outcome.log is not None:
        _write_atomic(run_dir / LOG_FILE, outcome.log)
    lines = "".join(f"{line}\n" for line in outcome.log_lines)
    _write_atomic(run_dir / RUN_LOG_FILE, lines.encode())
    log = run_dir / LOG_FILE
    result = {
        "status": outcome.status.value,
        "reason": outcome.reason,
        "spec": outcome.spec.to_json(),
        "config": plan.source,
        "run_digest": plan.digests.get(outcome.spec, ""),
        "metrics": outcome.metrics,
        "wall_clock_s": outcome.wall_clock_s,
        "sim_time_s": outcome.sim_time_s,
        "log_size_bytes": log.stat().st_size if log.exists() else None,
        "warnings": len(outcome.log_lines),
        "engine": engine,
        "worker": outcome.worker,
        "finished_unix_s": time.time(),
    }
    _write_atomic(run_dir / RESULT_FILE, (json.dumps(result, indent=2) + "\n").encode())
    return run_dir


def prepare_folder(out_dir: Path, plan: SweepPlan, engine: str, workers: int) -> None:
    """Create DIR, refusing one that holds a sweep of another scenario (by name: a changed
    config of the same name re-flies the runs it changes)."""
    manifest_path = out_dir / MANIFEST_FILE
    if manifest_path.exists():
        old = json.loads(manifest_path.read_text(encoding="utf-8"))
        if old.get("name") != plan.base.scenario.name:
            raise SweepError(
                f"{out_dir} holds a sweep of scenario {old.get('name')!r} ({old.get('config')}), "
                f"not {plan.base.scenario.name!r}; choose another --out"
            )
    out_dir.mkdir(parents=True, exist_ok=True)
    manifest = {**plan.manifest(), "engine": engine, "workers": workers}
    _write_atomic(manifest_path, (json.dumps(manifest, indent=2) + "\n").encode())
    text = yaml.safe_dump(to_mapping(plan.base), sort_keys=False)
    _write_atomic(out_dir / SCENARIO_FILE, text.encode())
