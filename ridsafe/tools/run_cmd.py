"""``ridsafe run``: fly a whole scenario end to end, log it, print its metrics.

live (default): the sim backend, the GCS and the companions run as separate processes over
MAVLink/UDP on 127.0.0.1, in real time or ``--speed`` times faster. lockstep: the same cores
and bytes in one process, advanced by one clock as fast as the CPU allows, deterministic for
a seed. Both leave ``OUT/run.mcap`` and ``OUT/summary.json`` (the metrics, computed from the
log).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import sys
import time
from pathlib import Path
from typing import NoReturn

import yaml
from tqdm import tqdm

from ridsafe.common import topics
from ridsafe.common.config import to_mapping
from ridsafe.common.errors import RidsafeError
from ridsafe.common.udp import parse_connection_string
from ridsafe.companion.planners import PLANNERS
from ridsafe.tools import assemble, live, runtime
from ridsafe.tools.lockstep import run_lockstep, warm_up
from ridsafe.tools.metrics import compute_metrics
from ridsafe.tools.scenario import ScenarioFile, with_aircraft

COMPANIONS_PER_PROCESS = 8


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "run",
        help="fly a whole scenario (sim, GCS, companions), log it to MCAP, print metrics",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    runtime.add_scenario_arguments(parser)
    parser.add_argument("--out", type=Path, help="output folder (default out/run-<time>)")
    parser.add_argument("--mode", choices=("live", "lockstep"), default="live")
    parser.add_argument("--seed", type=int, help="scenario seed")
    parser.add_argument("--speed", type=float, default=1.0, help="live: sim s per wall s")
    parser.add_argument("--aircraft", type=int, help="number of benign aircraft (rescales)")
    parser.add_argument("--planner", choices=sorted(PLANNERS), help="default: run.planner")
    parser.add_argument("--duration", type=float, help="flight time (s), default the scenario's")
    parser.add_argument("--json", action="store_true", help="print the metrics as JSON")
    parser.set_defaults(func=run)


def effective_scenario(args: argparse.Namespace) -> ScenarioFile:
    """The scenario file with every command-line override applied."""
    loaded = runtime.load_scenario_args(args)
    changes: dict[str, object] = {}
    if args.seed is not None:
        changes["seed"] = args.seed
    if args.duration is not None:
        changes["duration_s"] = args.duration
    if changes:
        scenario = dataclasses.replace(loaded.scenario, **changes)  # type: ignore[arg-type]
        loaded = dataclasses.replace(loaded, scenario=scenario)
    if args.aircraft is not None:
        loaded = with_aircraft(loaded, args.aircraft)
    return loaded


def run(args: argparse.Namespace) -> int:
    try:
        loaded = effective_scenario(args)
        planner = args.planner or loaded.run.planner
        if planner not in PLANNERS:
            raise ValueError(f"unknown planner {planner!r} (known: {', '.join(PLANNERS)})")
        runtime.check_speed(args)
    except (RidsafeError, ValueError, OSError) as exc:
        print(f"ridsafe run: {exc}", file=sys.stderr)
        return 2
    out = args.out or Path("out") / time.strftime("run-%Y%m%d-%H%M%S")
    out.mkdir(parents=True, exist_ok=True)
    scenario_path = out / "scenario.yaml"
    scenario_path.write_text(yaml.safe_dump(to_mapping(loaded), sort_keys=False))
    n = len(loaded.scenario.aircraft)
    spoofer = "1 spoofer" if loaded.scenario.spoofer is not None else "no spoofer"
    print(
        f"{loaded.scenario.name}: {n} aircraft + {spoofer}, {loaded.scenario.duration_s:g} s, "
        f"seed {loaded.scenario.seed}, planner {planner}, {args.mode} -> {out}",
        file=sys.stderr if args.json else sys.stdout,
        flush=True,
    )
    if args.mode == "lockstep":
        status, reason = _lockstep(loaded, planner, out)
    else:
        status, reason = _live(loaded, planner, out, scenario_path, args.speed)
    return _report(out, status, reason, args.json)


class _SimTimeBar:
    """A progress bar (with ETA) over sim seconds."""

    def __init__(self, duration_s: float) -> None:
        self.total = round(duration_s)
        self.bar: tqdm[NoReturn] = tqdm(
            total=self.total, unit="s", desc="sim time", leave=False, ncols=80
        )

    def __call__(self, now_s: float) -> None:
        done = min(math.floor(now_s), self.total)
        if done > self.bar.n:
            self.bar.update(done - self.bar.n)

    def close(self) -> None:
        self.bar.close()


def _lockstep(loaded: ScenarioFile, planner: str, out: Path) -> tuple[str, str]:
    bar = _SimTimeBar(loaded.scenario.duration_s)
    try:
        result = run_lockstep(loaded, planner, out / "run.mcap", bar)
    finally:
        bar.close()
    return result.status, result.reason


def _live(
    loaded: ScenarioFile, planner: str, out: Path, scenario_path: Path, speed: float
) -> tuple[str, str]:
    from ridsafe.tools.recorder import McapRecorder, merge_parts  # noqa: PLC0415

    duration = loaded.scenario.duration_s
    parts = out / "parts"
    print("compiled kernels: ", end="", file=sys.stderr, flush=True)
    warm_s = warm_up(loaded, planner)
    print(f"ready in {warm_s:.1f} s", file=sys.stderr, flush=True)
    t0 = time.time() + live.STARTUP_MARGIN_S
    children = _children(loaded, planner, out, scenario_path, speed, t0)
    own = parts / "run.mcap"
    foxglove = loaded.run.foxglove_channels
    with McapRecorder(own, origin=loaded.scenario.origin, foxglove=foxglove) as recorder:
        assemble.log_meta(recorder, assemble.run_meta(loaded, "live", planner))
        bar = _SimTimeBar(duration)
        try:
            outcome = live.supervise(children, duration, speed, t0, bar)
        finally:
            bar.close()
        end_s = min(duration, max(0.0, (time.time() - t0) * speed))
        recorder.log(
            topics.RUN_END,
            end_s,
            assemble.run_end(outcome.wall_clock_s, end_s, outcome.status, outcome.reason),
        )
    report = merge_parts(sorted(parts.glob("*.mcap")), out / "run.mcap")
    for part in report.parts:
        if not part.complete:
            print(f"note: {part.path.name} was cut off ({part.error}); kept its {part.messages} "
                  "readable messages", file=sys.stderr)  # fmt: skip
    return outcome.status, outcome.reason


def _children(
    loaded: ScenarioFile, planner: str, out: Path, scenario_path: Path, speed: float, t0: float
) -> list[live.Child]:
    duration = loaded.scenario.duration_s
    common = [str(scenario_path), "--speed", repr(speed), "--duration", repr(duration)]
    common += ["--t0-unix", repr(t0)]
    signing: list[str] = []
    if loaded.run.sign_gcs_links:
        key = out / "mavlink.key"
        key.write_text(os.urandom(32).hex())
        key.chmod(0o600)
        signing = ["--signing-key", str(key)]
    listen = parse_connection_string(loaded.run.gcs_listen)
    gcs_out = f"udpout:{listen.host}:{listen.port}"
    parts, logs = out / "parts", out / "logs"
    children = [
        live.Child("sim", live.cli_argv("sim", *common, "--log", str(parts / "sim.mcap")),
                   logs / "sim.log"),
        live.Child("gcs", live.cli_argv("gcs", *common, "--listen", loaded.run.gcs_listen,
                                        *signing, "--log", str(parts / "gcs.mcap")),
                   logs / "gcs.log"),
    ]  # fmt: skip
    ids = list(assemble.companion_ids(loaded))
    for first in range(0, len(ids), COMPANIONS_PER_PROCESS):
        group = ids[first : first + COMPANIONS_PER_PROCESS]
        name = f"companions-{group[0]}-{group[-1]}"
        argv = live.cli_argv(
            "companion", *common, "--vehicle", f"{group[0]}-{group[-1]}", "--gcs", gcs_out,
            "--planner", planner, *signing, "--log", str(parts / f"{name}.mcap"),
        )  # fmt: skip
        children.append(live.Child(name, argv, logs / f"{name}.log"))
    return children


def _report(out: Path, status: str, reason: str, as_json: bool) -> int:
    log = out / "run.mcap"
    try:
        metrics = compute_metrics(log)
    except RidsafeError as exc:
        print(f"ridsafe run: no metrics: {exc}", file=sys.stderr)
        return 1
    summary = {"status": status, "reason": reason, "log": str(log), "metrics": metrics}
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    if as_json:
        print(json.dumps(summary, indent=2))
    else:
        print(f"run {status}{': ' + reason if reason else ''}; log {log}")
        for key, value in metrics.items():
            text = "n/a" if value is None else f"{value:.4g}" if isinstance(value, float) else value
            print(f"  {key:28s} {text}")
        print(f"metrics in {out / 'summary.json'}")
    return 0 if status == "completed" else 1
