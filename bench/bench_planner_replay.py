"""Benchmark: the aware planner's cost per decision on the decisions of a real lockstep run,
timed in the run and replayed in a process that runs nothing else.

    python bench/bench_planner_replay.py [--config configs/paper.yaml] [--aircraft 16]
                                         [--seed 0] [--duration S] [--repeat 3]

One lockstep run (aware planner, nothing logged) with every companion's planner wrapped: each
decision's input is kept and its ``plan`` timed in the run. Then the same inputs go, in the
same order, through fresh planners of the same configuration ``--repeat`` times in this
process (the planner keeps its arrival latch and progress watchdog between calls, so each
aircraft gets its own); every replayed decision must equal the run's (target, velocity,
status, value, detail), or the script stops. Printed: p50, p99 and mean per decision in the
run and replayed (per decision the median over the repeats), the compiled scoring's share
of the replayed time (``planner_eval.score_actions``, timed once more), and how many of the
actions each decision scored (``RolloutScores.n_scored``, of ``len(actions)``).

``bench/bench_planner.py`` times synthetic worst cases (every neighbour within d_safe); this
times what the runs ask. The replay is where to profile the planner, and the equality check
is a bit-for-bit test of any change to it on the run's own decisions.
"""

from __future__ import annotations

import os

# As the ridsafe command line does (ridsafe/tools/cli/entry_point.py): no BLAS worker threads.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import logging  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ridsafe.common.logsink import NullSink  # noqa: E402
from ridsafe.companion import planner as planner_module  # noqa: E402
from ridsafe.companion.planner import FastMdpPlanner  # noqa: E402
from ridsafe.companion.planner_api import PlannerDecision, PlannerInput  # noqa: E402
from ridsafe.companion.planner_config import PlannerConfig  # noqa: E402
from ridsafe.tools.run.lockstep import build  # noqa: E402
from ridsafe.tools.run.scenario import REPO_ROOT, load_scenario_file, with_aircraft  # noqa: E402

Decision = tuple[int, PlannerConfig, PlannerInput, PlannerDecision]  # aircraft, cfg, in, out


def _fly(args: argparse.Namespace) -> tuple[list[Decision], np.ndarray]:
    """The run's decisions, in order, and each one's time in the run (s)."""
    loaded = load_scenario_file(args.config)
    scenario = dataclasses.replace(loaded.scenario, seed=args.seed, duration_s=args.duration)
    loaded = with_aircraft(dataclasses.replace(loaded, scenario=scenario), args.aircraft)
    run = build(loaded, "aware", NullSink())
    decisions: list[Decision] = []
    times: list[float] = []
    for sysid, companion in run.companions.items():
        planner = companion.pilot.planner
        if not isinstance(planner, FastMdpPlanner):
            raise SystemExit(f"aircraft {sysid}: planner {planner.name!r}, not the aware one")
        companion.pilot.planner = _Recording(sysid, planner, decisions, times)
    print(f"{args.config.name}, {args.aircraft} aircraft, seed {args.seed}: flying ...", flush=True)
    while run.t_s < args.duration - 1e-9:
        run.step()
    run.finish()
    return decisions, np.asarray(times)


class _Recording:
    """A planner whose decisions are kept with their inputs and timed."""

    def __init__(
        self, sysid: int, inner: FastMdpPlanner, decisions: list[Decision], times: list[float]
    ) -> None:
        self.sysid, self.inner, self.decisions, self.times = sysid, inner, decisions, times

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)

    def plan(self, planner_input: PlannerInput) -> PlannerDecision:
        start = time.perf_counter()
        decision = self.inner.plan(planner_input)
        self.times.append(time.perf_counter() - start)
        self.decisions.append((self.sysid, self.inner.config, planner_input, decision))
        return decision


def _replay(decisions: list[Decision]) -> np.ndarray:
    """Each decision's time (s) in fresh planners; stops at the first that differs."""
    planners: dict[int, FastMdpPlanner] = {}
    times = np.empty(len(decisions))
    for i, (sysid, cfg, planner_input, want) in enumerate(decisions):
        planner = planners.get(sysid)
        if planner is None:
            planner = planners[sysid] = FastMdpPlanner(planner_module.AWARE, cfg)
            planner.warm_up()
        start = time.perf_counter()
        got = planner.plan(planner_input)
        times[i] = time.perf_counter() - start
        if got != want:
            raise SystemExit(f"decision {i} (aircraft {sysid}) differs: {got} != {want}")
    return times


def _scoring(decisions: list[Decision]) -> tuple[float, np.ndarray, int]:
    """(time in ``score_actions``, actions scored per decision, actions per decision) of one
    more replay."""
    spent = [0.0]
    scored: list[int] = []
    n_actions = [0]
    names = vars(planner_module)  # plan() looks score_actions up there at each call
    inner = names["score_actions"]

    def timed(*args: Any, **kwargs: Any) -> Any:
        start = time.perf_counter()
        scores = inner(*args, **kwargs)
        spent[0] += time.perf_counter() - start
        scored.append(scores.n_scored)
        n_actions[0] = len(scores.goal)
        return scores

    names["score_actions"] = timed
    try:
        _replay(decisions)
    finally:
        names["score_actions"] = inner
    return spent[0], np.asarray(scored), n_actions[0]


def _summary(times_s: np.ndarray) -> str:
    us = times_s * 1e6
    p50, p99 = np.percentile(us, [50, 99])
    return f"p50 {p50:.0f} us  p99 {p99:.0f} us  mean {us.mean():.0f} us"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", type=Path, default=REPO_ROOT / "configs" / "paper.yaml")
    parser.add_argument("--aircraft", type=int, default=16)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--duration", type=float, default=120.0)
    parser.add_argument("--repeat", type=int, default=3, help="replays of the decisions")
    args = parser.parse_args()
    if args.repeat < 1:
        parser.error("--repeat: must be >= 1")
    logging.basicConfig(level=logging.ERROR)
    decisions, in_run = _fly(args)
    if not decisions:
        raise SystemExit("the run made no decision")
    replayed = np.median(np.array([_replay(decisions) for _ in range(args.repeat)]), axis=0)
    scoring_s, scored, n_actions = _scoring(decisions)
    print(f"  {len(decisions)} decisions of {len(set(d[0] for d in decisions))} aircraft")
    print(f"  in the run: {_summary(in_run)}")
    print(f"  replayed (median of {args.repeat}, every decision the run's): {_summary(replayed)}")
    print(
        f"  scoring (compiled kernel and its arguments): {scoring_s:.2f} s of "
        f"{replayed.sum():.2f} s replayed ({100 * scoring_s / replayed.sum():.0f} %)"
    )
    p50, p90 = np.percentile(scored, [50, 90])
    print(
        f"  actions scored of {n_actions}: p50 {p50:.0f}, p90 {p90:.0f}, mean {scored.mean():.0f};"
        f" {np.count_nonzero(scored >= 600)} decisions scored 600 or more"
    )


if __name__ == "__main__":
    main()
