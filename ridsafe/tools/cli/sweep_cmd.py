"""``ridsafe sweep``: fly the experiment matrix in lockstep, resumably, on every core or on Dask.

    ridsafe sweep configs/paper.yaml                    # 4 densities x 30 seeds x 2 planners
    ridsafe sweep configs/paper.yaml --densities 4,8 --seeds 0:2 --duration 20 --out out/try
    ridsafe sweep configs/paper.yaml --vary pipeline.region.alpha=0.01,0.05
    ridsafe sweep X --vary rssi:scenario.radio.shadowing_sigma_db+pipeline.rssi_sigma_db=1.0,2.0
    ridsafe sweep configs/paper.yaml --engine dask                 # a local Dask cluster
    ridsafe sweep configs/paper.yaml --scheduler tcp://10.0.0.5:8786  # an existing one

The matrix comes from the config's optional ``sweep:`` section (densities, seeds, planners,
duration_s, params: {name: {keys: [...], values: [...]}}), else the paper's; flags override
it (``--vary`` adds or replaces one axis). Each run: DIR/n{density}/{planner}/seed{seed:03d}
[/{axis}={value}]/ with run.mcap (every record; the derived Foxglove channels only with
``--foxglove``), result.json and run.log. Running the same command again skips finished
runs. A failed run is recorded and the sweep goes on. Then: ridsafe report DIR.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import NoReturn

from tqdm import tqdm

from ridsafe.common.config import parse_override, parse_yaml
from ridsafe.common.errors import RidsafeError
from ridsafe.tools.cli.arg_types import int_list, positive_float, positive_int, seed_list
from ridsafe.tools.run.scenario import check_no_drawn_overrides
from ridsafe.tools.sweep.config import ParamAxis, ParamValue, SweepConfig
from ridsafe.tools.sweep.engines import DaskEngine, LocalPoolEngine, default_workers
from ridsafe.tools.sweep.folder import RunOutcome, RunStatus, is_finished
from ridsafe.tools.sweep.plan import (
    RunSpec,
    SweepError,
    SweepPlan,
    check_plan,
    load_sweep_file,
    plan_sweep,
)
from ridsafe.tools.sweep.runner import Engine, SweepSummary, run_sweep


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "sweep",
        help="fly the experiment matrix (densities x seeds x planners x ...) in lockstep",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("config", type=Path, help="scenario YAML, optionally with a sweep: section")
    parser.add_argument("--out", type=Path, help="sweep folder (default out/sweep-<config name>)")
    parser.add_argument("--engine", choices=("pool", "dask"), default="pool")
    parser.add_argument(
        "--workers", type=positive_int, help=f"default: every core ({default_workers()})"
    )
    parser.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler (implies dask)")
    parser.add_argument(
        "--densities", type=int_list, help="benign aircraft per scenario, e.g. 4,8,12,16"
    )
    parser.add_argument("--seeds", type=seed_list, help="e.g. 0:30 (start:stop) or 0,1,5")
    parser.add_argument("--planners", help="e.g. aware,trust-rid")
    parser.add_argument("--duration", type=positive_float, help="flight time (s) of every run")
    parser.add_argument(
        "--vary",
        action="append",
        default=[],
        metavar="[NAME:]KEY[+KEY]=V1,V2",
        help="an extra axis: each value set at every KEY (name: the first key's last part)",
    )
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a config value in every run, e.g. --set pipeline.region.alpha=0.1",
    )
    parser.add_argument(
        "--foxglove",
        action="store_true",
        help="keep the derived Foxglove channels (3D scene, map) in every run's log",
    )
    parser.add_argument("--dry-run", action="store_true", help="list the matrix, fly nothing")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.set_defaults(func=run)


def parse_vary(text: str) -> tuple[str, ParamAxis]:
    """``[NAME:]KEY[+KEY...]=V1,V2`` -> (name, axis); values are YAML scalars."""
    left, sep, right = text.partition("=")
    if not sep or not left or not right:
        raise ValueError(f"--vary: expected [NAME:]KEY[+KEY]=V1,V2, got {text!r}")
    name, colon, keys_text = left.partition(":")
    if not colon:
        name, keys_text = "", left
    keys = tuple(key.strip() for key in keys_text.split("+"))
    values = tuple(_scalar(raw, text) for raw in right.split(","))
    return name or keys[0].rsplit(".", 1)[-1], ParamAxis(keys, values)


def _scalar(raw: str, text: str) -> ParamValue:
    value = parse_yaml(raw, f"--vary {text}")
    if not isinstance(value, bool | int | float | str):
        raise ValueError(f"--vary: values are numbers, booleans or words, got {raw!r}")
    return value


def _ints(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(part) for part in text.split(","))
    except ValueError:
        raise ValueError(f"expected comma-separated integers, got {text!r}") from None


def sweep_config(args: argparse.Namespace, config: SweepConfig) -> SweepConfig:
    """The config's matrix with the command line's flags applied."""
    changes: dict[str, object] = {}
    if args.densities is not None:
        changes["densities"] = _ints(args.densities)
    if args.seeds is not None:
        changes["seeds"] = args.seeds
    if args.planners is not None:
        changes["planners"] = tuple(p.strip() for p in args.planners.split(","))
    if args.duration is not None:
        changes["duration_s"] = args.duration
    if args.vary:
        changes["params"] = {**config.params, **dict(parse_vary(text) for text in args.vary)}
    if args.foxglove:
        changes["foxglove_channels"] = True
    return dataclasses.replace(config, **changes)  # type: ignore[arg-type]


def make_engine(args: argparse.Namespace) -> Engine:
    workers = args.workers if args.workers is not None else default_workers()
    if workers < 1:
        raise ValueError(f"--workers must be >= 1, got {workers}")
    if args.engine == "dask" or args.scheduler is not None:
        return DaskEngine(workers=workers, scheduler=args.scheduler)
    return LocalPoolEngine(workers=workers)


def make_plan(args: argparse.Namespace) -> SweepPlan:
    overrides = dict(parse_override(text) for text in args.overrides)
    base, config = load_sweep_file(args.config, overrides)
    check_no_drawn_overrides(base, overrides)
    matrix = sweep_config(args, config)
    for name, axis in matrix.params.items():
        for key in sorted(set(axis.keys) & set(overrides)):
            raise ValueError(
                f"--set {key}: the sweep's axis '{name}' sets it for every run, so this value "
                f"would never be flown; give its values with --vary {name}:{key}=V1,V2"
            )
    plan = plan_sweep(base, matrix, str(args.config))
    check_plan(plan)
    return plan


def run(args: argparse.Namespace) -> int:
    try:
        plan = make_plan(args)
        engine = make_engine(args)
    except (RidsafeError, ValueError, OSError) as exc:
        print(f"ridsafe sweep: {exc}", file=sys.stderr)
        return 2
    out: Path = args.out or Path("out") / f"sweep-{args.config.stem}"
    print(_headline(plan, engine, out), flush=True)
    if args.dry_run:
        done = sum(1 for spec in plan.specs if is_finished(out / spec.run_dir, plan.digests[spec]))
        print(f"{done} of {len(plan.specs)} runs finished; first: {plan.specs[0].run_dir}")
        return 0
    bar = ProgressBar(enabled=not args.no_progress)
    try:
        summary = run_sweep(plan, out, engine, bar)
    except (SweepError, OSError) as exc:  # OSError: a folder we cannot write, no scheduler
        print(f"ridsafe sweep: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("\ninterrupted: finished runs are kept; the same command resumes", file=sys.stderr)
        return 130
    finally:
        bar.close()
    _print_summary(summary, bar.outcomes, out)
    return 1 if summary.failed else 0


def _headline(plan: SweepPlan, engine: Engine, out: Path) -> str:
    config = plan.config
    axes = "".join(f" x {len(axis.values)} {name}" for name, axis in config.params.items())
    matrix = (
        f"{len(config.densities)} densit{'y' if len(config.densities) == 1 else 'ies'} "
        f"{list(config.densities)} x "
        f"{len(config.seed_values)} seeds x {len(config.planners)} planners{axes}"
    )
    scheduler = engine.scheduler if isinstance(engine, DaskEngine) else None
    workers = f"scheduler {scheduler}" if scheduler else f"{engine.workers} workers"
    return (
        f"{plan.source}: {len(plan.specs)} runs ({matrix}), {plan.specs[0].duration_s:g} s "
        f"each; {engine.name} engine, {workers} -> {out}"
    )


class ProgressBar:
    """A tqdm bar over the runs, weighted by cost (:attr:`RunSpec.weight`), with an ETA from
    the average rate since the start (runs differ too much in cost for a moving average)."""

    def __init__(self, enabled: bool = True) -> None:
        self.enabled = enabled
        self.bar: tqdm[NoReturn] | None = None
        self.outcomes: list[RunOutcome] = []
        self.runs_total = self.runs_done = self.problems = 0

    def start(self, specs: Sequence[RunSpec], todo: Sequence[RunSpec]) -> None:
        self.runs_total, self.runs_done = len(specs), len(specs) - len(todo)
        total = sum(spec.weight for spec in specs)
        self.bar = tqdm(
            total=total,
            initial=total - sum(spec.weight for spec in todo),
            disable=not (self.enabled and todo),
            smoothing=0.0,
            dynamic_ncols=True,
            bar_format="{desc} {percentage:3.0f}%|{bar}| [{elapsed}<{remaining}]",
        )
        self._describe()

    def finished(self, outcome: RunOutcome) -> None:
        self.outcomes.append(outcome)
        self.runs_done += 1
        self.problems += outcome.status is not RunStatus.COMPLETED
        self._describe()
        if self.bar is not None:
            self.bar.update(outcome.spec.weight)

    def _describe(self) -> None:
        if self.bar is not None:
            text = f"sweep: {self.runs_done}/{self.runs_total} runs"
            self.bar.set_description_str(
                text + (f", {self.problems} failed" if self.problems else "")
            )

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _print_summary(summary: SweepSummary, outcomes: Sequence[RunOutcome], out: Path) -> None:
    flown = summary.completed + len(summary.failed)
    rate = 60.0 * flown / summary.wall_clock_s if summary.wall_clock_s > 0 else 0.0
    print(
        f"{summary.total} runs: {summary.skipped} already done, {summary.completed} completed, "
        f"{len(summary.failed)} failed, in {summary.wall_clock_s:.0f} s ({rate:.1f} runs/min)"
    )
    walls: dict[int, list[float]] = defaultdict(list)
    for outcome in outcomes:
        if outcome.status is RunStatus.COMPLETED:
            walls[outcome.spec.density].append(outcome.wall_clock_s)
    if walls:
        per = ", ".join(f"n{n} {sum(w) / len(w):.1f} s" for n, w in sorted(walls.items()))
        print(f"mean wall clock per run: {per}")
    for outcome in summary.failed:
        lines = outcome.reason.strip().splitlines() or [outcome.status.value]
        where = out / outcome.spec.run_dir / "result.json"
        print(f"  {outcome.status.value}: {outcome.spec.run_dir}: {lines[-1]} ({where})")
    print(f"report: ridsafe report {out}")
