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
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

import yaml
from tqdm import tqdm

from ridsafe.common.adversary import AdversaryRole
from ridsafe.common.config import to_mapping
from ridsafe.common.errors import RidsafeError
from ridsafe.companion.planners import PLANNERS
from ridsafe.tools.analysis.metrics import compute_metrics
from ridsafe.tools.cli import app_args
from ridsafe.tools.cli.arg_types import non_negative_int, positive_float, positive_int
from ridsafe.tools.run.live import run_live
from ridsafe.tools.run.lockstep import run_lockstep
from ridsafe.tools.run.scenario import ScenarioFile, with_aircraft

if TYPE_CHECKING:
    from ridsafe.tools.runlog.foxglove_live import FoxgloveLiveServer as LiveServer


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "run",
        help="fly a whole scenario (sim, GCS, companions), log it to MCAP, print metrics",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    app_args.add_scenario_arguments(parser)
    parser.add_argument("--out", type=Path, help="output folder (default out/run-<time>)")
    parser.add_argument("--mode", choices=("live", "lockstep"), default="live")
    parser.add_argument("--seed", type=non_negative_int, help="scenario seed")
    parser.add_argument("--speed", type=positive_float, default=1.0, help="live: sim s per wall s")
    parser.add_argument(
        "--aircraft", type=positive_int, help="number of benign aircraft (rescales)"
    )
    parser.add_argument("--planner", choices=sorted(PLANNERS), help="default: run.planner")
    parser.add_argument(
        "--duration", type=positive_float, help="flight time (s), default the scenario's"
    )
    parser.add_argument("--json", action="store_true", help="print the metrics as JSON")
    parser.add_argument(
        "--one-process",
        action="store_true",
        help="lockstep: every core in this process (default: two where two CPUs are free)",
    )
    parser.add_argument(
        "--foxglove",
        metavar="[HOST:]PORT",
        help="serve the run's channels live to the Foxglove app (WebSocket; host default "
        "127.0.0.1; needs the 'live' extra). live mode: the sim's channels",
    )
    parser.set_defaults(func=run)


def effective_scenario(args: argparse.Namespace) -> ScenarioFile:
    """The scenario file with every command-line override applied."""
    loaded = app_args.load_scenario_args(args)
    changes: dict[str, object] = {}
    if args.seed is not None:
        changes["seed"] = args.seed
    if args.duration is not None:
        changes["duration_s"] = args.duration
    if changes:
        scenario = dataclasses.replace(loaded.scenario, **changes)  # type: ignore[arg-type]
        loaded = dataclasses.replace(loaded, scenario=scenario)
    if args.aircraft is not None:
        loaded = with_aircraft(loaded, args.aircraft, app_args.override_pairs(args))
    return loaded


def run(args: argparse.Namespace) -> int:
    try:
        loaded = effective_scenario(args)
        planner = args.planner or loaded.run.planner
        if planner not in PLANNERS:
            raise ValueError(f"unknown planner {planner!r} (known: {', '.join(PLANNERS)})")
        app_args.check_speed(args)
        if args.one_process and args.mode != "lockstep":
            raise ValueError("--one-process: only with --mode lockstep (live runs one per app)")
        if args.foxglove:
            from ridsafe.tools.runlog.foxglove_live import parse_host_port  # noqa: PLC0415

            parse_host_port(args.foxglove)
    except (RidsafeError, ValueError, OSError) as exc:
        print(f"ridsafe run: {exc}", file=sys.stderr)
        return 2
    out = args.out or Path("out") / time.strftime("run-%Y%m%d-%H%M%S")
    out.mkdir(parents=True, exist_ok=True)
    scenario_path = out / "scenario.yaml"
    scenario_path.write_text(yaml.safe_dump(to_mapping(loaded), sort_keys=False))
    n = len(loaded.scenario.aircraft)
    roles = [s.role for s in loaded.scenario.all_spoofers]
    n_spoofers = roles.count(AdversaryRole.SPOOFER)
    n_bystanders = roles.count(AdversaryRole.BYSTANDER)
    n_ghosts = len(loaded.scenario.ghosts)
    spoofer = f"{n_spoofers or 'no'} spoofer{'' if n_spoofers == 1 else 's'}"
    spoofer += f" + {n_ghosts} ghost{'' if n_ghosts == 1 else 's'}" if n_ghosts else ""
    if n_bystanders:
        spoofer += f" + {n_bystanders} bystander{'' if n_bystanders == 1 else 's'}"
    print(
        f"{loaded.scenario.name}: {n} aircraft + {spoofer}, {loaded.scenario.duration_s:g} s, "
        f"seed {loaded.scenario.seed}, planner {planner}, {args.mode} -> {out}",
        file=sys.stderr if args.json else sys.stdout,
        flush=True,
    )
    if args.mode == "lockstep":
        status, reason = _lockstep(loaded, planner, out, args.foxglove, args.one_process)
    else:
        status, reason = _live(loaded, planner, out, scenario_path, args.speed, args.foxglove)
    return _report(out, status, reason, args.json)


#: Said before the kernels are loaded, which on a fresh install (or after an edit) means
#: compiled: numba caches them beside their modules, so only the first run waits.
KERNELS_NOTICE = "compiled kernels (the first run after install compiles them, ~40 s): "


def _say_ready(seconds: float) -> None:
    print(f"ready in {seconds:.1f} s", file=sys.stderr, flush=True)


class _SimTimeBar:
    """A progress bar (with ETA) over sim seconds, drawn from the first progress report.
    ``announce``: say ``KERNELS_NOTICE`` now and "ready" at the first report (a lockstep
    run reports its first tick once its cores, kernels included, are built)."""

    def __init__(self, duration_s: float, announce: bool = False) -> None:
        self.total = round(duration_s)
        self.bar: tqdm[NoReturn] | None = None
        self._announced_at = time.perf_counter() if announce else None
        if announce:
            print(KERNELS_NOTICE, end="", file=sys.stderr, flush=True)

    def __call__(self, now_s: float) -> None:
        if self.bar is None:
            if self._announced_at is not None:
                _say_ready(time.perf_counter() - self._announced_at)
            self.bar = tqdm(total=self.total, unit="s", desc="sim time", leave=False, ncols=80)
        done = min(math.floor(now_s), self.total)
        if done > self.bar.n:
            self.bar.update(done - self.bar.n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
        elif self._announced_at is not None:  # stopped before the first tick: end the line
            print("stopped", file=sys.stderr, flush=True)


def _lockstep(
    loaded: ScenarioFile, planner: str, out: Path, foxglove: str | None, one_process: bool
) -> tuple[str, str]:
    live: LiveServer | None = None
    bar: _SimTimeBar | None = None
    try:
        if foxglove:
            from ridsafe.tools.runlog import foxglove_live  # noqa: PLC0415 (an optional extra)

            live = foxglove_live.FoxgloveLiveServer(
                *foxglove_live.parse_host_port(foxglove), loaded.scenario.origin
            )
            print(f"Foxglove: open {live.url}", file=sys.stderr, flush=True)
        bar = _SimTimeBar(loaded.scenario.duration_s, announce=True)
        split = False if one_process else None  # None: two processes where they help
        result = run_lockstep(loaded, planner, out / "run.mcap", bar, live=live, split=split)
    finally:
        if bar is not None:
            bar.close()
        if live is not None:
            live.close()
    return result.status, result.reason


def _live(
    loaded: ScenarioFile,
    planner: str,
    out: Path,
    scenario_path: Path,
    speed: float,
    foxglove: str | None,
) -> tuple[str, str]:
    print(KERNELS_NOTICE, end="", file=sys.stderr, flush=True)
    bar = _SimTimeBar(loaded.scenario.duration_s)
    try:
        outcome = run_live(loaded, planner, out, scenario_path, speed, bar, _say_ready, foxglove)
    finally:
        bar.close()
    for note in outcome.notes:
        print(f"note: {note}", file=sys.stderr)
    return outcome.status, outcome.reason


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
        width = max(map(len, metrics), default=0)
        for key, value in metrics.items():
            text = "n/a" if value is None else f"{value:.4g}" if isinstance(value, float) else value
            print(f"  {key:{width}s} {text}")
        print(f"metrics in {out / 'summary.json'}")
    return 0 if status == "completed" else 1
