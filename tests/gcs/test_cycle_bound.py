"""The work bound per cycle (``max_claims_per_cycle``): aligned broadcasts spread over the
next cycles oldest first, evenly when they outnumber the bound, alerted transmitters never
wait and none waits too long, every claim runs exactly once, and under the bound nothing
changes."""

from __future__ import annotations

import dataclasses

import pytest

from ridsafe.common.errors import FieldValueError
from ridsafe.gcs.pipeline import EstimationPipeline
from ridsafe.gcs.pipeline_api import ObservedClaim
from ridsafe.gcs.pipeline_config import ForcedAlertConfig, PipelineConfig
from ridsafe.gcs.synthetic.traffic import CYCLE_S, SPOOFER_ID, Scene, make_traffic

N_DETECTORS = 5
SCENE = Scene(seed=2, n_receivers=11, duration_s=12.0, aligned_phases=True)


def _claims_run(cfg: PipelineConfig) -> list[list[str]]:
    """Per cycle: the uas_id of each claim the detectors saw (one per five results)."""
    traffic = make_traffic(SCENE)
    pipeline = EstimationPipeline(cfg)
    runs = []
    for k in range(1, round(SCENE.duration_s / CYCLE_S) + 1):
        now = round(k * CYCLE_S, 6)
        out = pipeline.step(now, traffic.cycles.get(now, []))
        runs.append([r.uas_id for r in out.detector_results][::N_DETECTORS])
    return runs


def test_at_most_the_bound_per_cycle_and_every_claim_once() -> None:
    unbounded = _claims_run(PipelineConfig(max_claims_per_cycle=0))
    bounded = _claims_run(PipelineConfig(max_claims_per_cycle=5))
    assert max(map(len, unbounded)) == SCENE.n_receivers + 1  # all in one cycle
    first_heard = next(k for k, run in enumerate(bounded) if run)
    assert len(bounded[first_heard]) == SCENE.n_receivers + 1  # new transmitters never wait
    assert max(map(len, bounded[first_heard + 1 :])) <= 5
    spoofer_runs = [k for k, run in enumerate(bounded) if SPOOFER_ID in run]
    assert all(k % 4 == first_heard % 4 for k in spoofer_runs)  # a suspect: never waits
    flat_unbounded = [u for run in unbounded for u in run]
    flat_bounded = [u for run in bounded for u in run]
    # once each (the last second's may still wait at the end), and per transmitter in order
    assert set(flat_bounded) == set(flat_unbounded)
    assert 0 <= len(flat_unbounded) - len(flat_bounded) <= SCENE.n_receivers + 1 - 5


@pytest.mark.parametrize(("wait_s", "per_cycle"), [(0.75, [3, 3, 3, 3]), (0.5, [4, 4, 4, 0])])
def test_more_claims_than_the_bound_spread_evenly_over_the_wait(
    wait_s: float, per_cycle: list[int]
) -> None:
    """12 aligned claims a second against a bound of 1: the least even number per cycle
    that runs each within ``max_claim_wait_s`` (4 cycles of 0.25 s, or 3), the spoofer's
    track update counted as one claim."""
    cfg = PipelineConfig(max_claims_per_cycle=1, max_claim_wait_s=wait_s, track_claim_cost=1)
    runs = _claims_run(cfg)
    first_heard = next(k for k, run in enumerate(runs) if run)
    steady = [len(run) for run in runs[first_heard + 4 :]]
    assert steady == per_cycle * (len(steady) // 4)


def test_a_cycle_that_updates_a_track_takes_fewer_waiting_claims() -> None:
    """The spoofer (alerted at 0 s, tracked) broadcasts in phase with 11 aircraft against a
    bound of 5: with its update counted as 30 claims its cycle runs it alone and the others
    spread over the next three (5, 5, 1), the same claims as when it counts as one."""
    forced = ForcedAlertConfig(enabled=True, uas_id=SPOOFER_ID, time_s=0.0)
    runs = {
        cost: _claims_run(
            PipelineConfig(max_claims_per_cycle=5, forced_alert=forced, track_claim_cost=cost)
        )
        for cost in (1, 30)
    }
    tracked = [k for k, run in enumerate(runs[30]) if SPOOFER_ID in run][2:]  # once tracked
    assert tracked and all(runs[30][k] == [SPOOFER_ID] for k in tracked)
    assert all(len(runs[1][k]) == 5 for k in tracked)  # counted as one: the bound's 5
    others = [len(run) for k, run in enumerate(runs[30]) if k > tracked[0] and k not in tracked]
    assert max(others) <= 5  # the 11 benign claims over the next three cycles
    flat = {cost: sorted(u for run in r[: tracked[-1]] for u in run) for cost, r in runs.items()}
    assert flat[1] == flat[30]  # the same claims ran by then


def test_the_waiting_claims_spread_over_the_cycles_a_track_update_leaves_free() -> None:
    """The spoofer (alerted at 0 s, tracked) broadcasts half a second after 11 aircraft that
    are in phase, against a bound of 3: its cycle has no room for waiting claims, so the
    fleet's 11 are spread over the other three of their 0.75 s wait (4, 4, 3), its next claim
    expected one period after its last; not 3, 3 and then the 5 left at the wait limit."""
    forced = ForcedAlertConfig(enabled=True, uas_id=SPOOFER_ID, time_s=0.0)
    traffic = make_traffic(SCENE)
    shifted: dict[float, list[ObservedClaim]] = {}
    for cycle, claims in traffic.cycles.items():
        for claim in claims:
            later = 2 * CYCLE_S if claim.uas_id == SPOOFER_ID else 0.0
            shifted.setdefault(round(cycle + later, 6), []).append(claim)
    pipeline = EstimationPipeline(PipelineConfig(max_claims_per_cycle=3, forced_alert=forced))
    runs = []
    for k in range(1, round(SCENE.duration_s / CYCLE_S) + 1):
        now = round(k * CYCLE_S, 6)
        out = pipeline.step(now, shifted.get(now, []))
        runs.append([r.uas_id for r in out.detector_results][::N_DETECTORS])
    tracked = [k for k, run in enumerate(runs) if SPOOFER_ID in run][3:]  # once predictable
    assert tracked and all(runs[k] == [SPOOFER_ID] for k in tracked)
    fleet = [len(run) for k, run in enumerate(runs) if tracked[0] < k < tracked[-1]]
    assert max(fleet) == 4  # ceil(11 / 3): the three cycles the track update leaves
    delivered = sum(len(claims) for cycle, claims in shifted.items() if cycle <= SCENE.duration_s)
    assert sum(map(len, runs)) + len(pipeline.waiting) == delivered  # every claim, once


def test_under_the_bound_nothing_changes() -> None:
    traffic = make_traffic(SCENE)
    outputs = []
    for limit in (0, SCENE.n_receivers + 1):
        pipeline = EstimationPipeline(PipelineConfig(max_claims_per_cycle=limit))
        outputs.append(
            [
                pipeline.step(round(k * CYCLE_S, 6), traffic.cycles.get(round(k * CYCLE_S, 6), []))
                for k in range(1, 40)
            ]
        )
    assert [o.detector_results for o in outputs[0]] == [o.detector_results for o in outputs[1]]


def test_alerted_and_overdue_claims_never_wait() -> None:
    forced = ForcedAlertConfig(enabled=True, uas_id=SPOOFER_ID, time_s=0.0)
    cfg = PipelineConfig(max_claims_per_cycle=2, forced_alert=forced)
    traffic = make_traffic(SCENE)
    pipeline = EstimationPipeline(cfg)
    pipeline.step(0.0, [])  # the forced alert
    for k in range(1, round(SCENE.duration_s / CYCLE_S) + 1):
        now = round(k * CYCLE_S, 6)
        new = traffic.cycles.get(now, [])
        out = pipeline.step(now, new)
        ran = {r.uas_id for r in out.detector_results}
        if any(c.uas_id == SPOOFER_ID for c in new):
            assert SPOOFER_ID in ran  # alerted: never waits
        for arrived_s, _claim in pipeline._waiting:
            assert now - arrived_s < cfg.max_claim_wait_s  # overdue ones ran


def test_the_bound_is_checked() -> None:
    with pytest.raises(FieldValueError, match="max_claims_per_cycle"):
        PipelineConfig(max_claims_per_cycle=-1)
    with pytest.raises(FieldValueError, match="max_claim_wait_s"):
        dataclasses.replace(PipelineConfig(), max_claim_wait_s=0.0)
    with pytest.raises(FieldValueError, match="track_claim_cost"):
        PipelineConfig(track_claim_cost=0)
