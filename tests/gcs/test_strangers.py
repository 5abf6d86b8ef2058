"""Strangers (``tracks.strangers_after_claims``): a transmitter no cooperative aircraft accounts
for is tracked before any alert, its region flagged unconfirmed; the alert stays the
detectors'. The labeller names them; the pipeline tracks them, and ends their tracks when
they go quiet or stop being strangers."""

from __future__ import annotations

import pytest

from ridsafe.common.errors import FieldValueError
from ridsafe.common.messages import AlertState
from ridsafe.gcs.calibration.config import CalibrationConfig
from ridsafe.gcs.calibration.cooperative import CooperativeLabeller
from ridsafe.gcs.calibration.pipeline import CalibratingPipeline
from ridsafe.gcs.pipeline import EstimationPipeline, Strangers
from ridsafe.gcs.pipeline_api import FORGET_AFTER_S, CycleOutput
from ridsafe.gcs.pipeline_config import ForcedAlertConfig, PipelineConfig, TrackConfig
from ridsafe.gcs.synthetic.traffic import CYCLE_S, SPOOFER_ID, Scene, Traffic, make_traffic
from tests.gcs.claims import free_space_claim

CAL = CalibrationConfig(enabled=True, min_samples=200, min_time_s=0.0)
FLEET = {1: [0.0, 0.0, 50.0], 2: [300.0, 0.0, 60.0], 3: [0.0, 400.0, 70.0]}
AWAY = [150.0, 150.0, 60.0]  # a spoofer's claim: 50 m and more from anyone
#: The real detectors only report: a forced alert that never comes (``detectors_also_alert``
#: false), so what tracks a transmitter here is its being a stranger alone.
NO_ALERTS = ForcedAlertConfig(enabled=True, uas_id="nobody", time_s=1e9)


def _labeller_after(seconds: int, spoofer_claims: list[list[float]]) -> CooperativeLabeller:
    """The fleet's three aircraft claiming where they are, once a second, and a spoofer
    claiming ``spoofer_claims[k]`` at second k."""
    lab = CooperativeLabeller(CAL)
    for k in range(seconds):
        t = float(k)
        for sysid, p in FLEET.items():
            others = {i: q for i, q in FLEET.items() if i != sysid}
            lab.observe(free_space_claim(f"RID{sysid}", t, p, others))
        heard_by = {i: q for i, q in FLEET.items() if q != spoofer_claims[k]}  # not by itself
        lab.observe(free_space_claim("SPOOF", t, spoofer_claims[k], heard_by))
    return lab


def test_the_labeller_names_a_serial_no_receiver_ever_accounted_for() -> None:
    lab = _labeller_after(5, [AWAY] * 5)
    assert lab.strangers(5) == {"SPOOF"}
    assert lab.strangers(6) == set()  # heard five times only
    # RID1's first claim matched nobody (nobody had reported its position yet): one claim
    # unaccounted for does not make a stranger of a serial whose later claims matched.
    assert lab.strangers(1) == {"SPOOF"}


def test_the_labeller_forgets_a_serial_silent_for_the_pipelines_forget_time() -> None:
    lab = _labeller_after(5, [AWAY] * 5)
    assert lab.labels().keys() == {"RID1", "RID2", "RID3"}
    # a spray: a new serial every 0.1 s for 200 s, while the fleet is silent
    sprayed = [f"NEW{k}" for k in range(2000)]
    for k, uas_id in enumerate(sprayed):
        lab.observe(free_space_claim(uas_id, 5.0 + 0.1 * k, AWAY, FLEET))
    # what was heard more than FORGET_AFTER_S before the newest claim is gone
    newest_s = 5.0 + 0.1 * (len(sprayed) - 1)
    recent = {u for k, u in enumerate(sprayed) if newest_s - (5.0 + 0.1 * k) <= FORGET_AFTER_S}
    assert lab.strangers(1) == recent and len(recent) < 0.35 * len(sprayed)
    assert lab.labels() == {}  # the fleet, silent as long, too
    # a forgotten serial heard again counts afresh
    for k in range(4):
        lab.observe(free_space_claim("SPOOF", newest_s + k, AWAY, FLEET))
    assert "SPOOF" in lab.strangers(4) and "SPOOF" not in lab.strangers(5)


def test_a_serial_that_once_claimed_a_receivers_own_position_is_no_stranger() -> None:
    """Left to the detectors, as before: the labeller cannot tell it from a fleet aircraft
    whose receiver was late."""
    lab = _labeller_after(6, [AWAY, AWAY, FLEET[2], AWAY, AWAY, AWAY])  # second 2: at RID2
    assert lab.strangers(3) == set()


def _run(
    traffic: Traffic, cfg: PipelineConfig, strangers: Strangers
) -> list[tuple[float, CycleOutput]]:
    pipeline = EstimationPipeline(cfg, strangers=strangers)
    out = []
    for k in range(1, round(traffic.scene.duration_s / CYCLE_S) + 1):
        now = round(k * CYCLE_S, 6)
        out.append((now, pipeline.step(now, traffic.cycles.get(now, []))))
    return out


def _spoofer_regions(cycles: list[tuple[float, CycleOutput]]) -> list[tuple[float, bool]]:
    return [(t, r.unconfirmed) for t, out in cycles for r in out.regions if r.uas_id == SPOOFER_ID]


def test_a_stranger_has_its_region_before_the_alert_flagged_unconfirmed_until_then() -> None:
    traffic = make_traffic(Scene(seed=3, n_receivers=12, duration_s=40.0))
    cycles = _run(traffic, PipelineConfig(), lambda: {SPOOFER_ID})
    (alert_s,) = [t for t, out in cycles for c in out.alert_changes if c.state is AlertState.RAISED]
    regions = _spoofer_regions(cycles)
    first_s = regions[0][0]
    assert first_s < alert_s  # planners keep clear of it while the detectors gather evidence
    assert [t for t, _ in regions] == [t for t, _ in cycles if t >= first_s]  # every cycle
    assert all(unconfirmed == (t < alert_s) for t, unconfirmed in regions)
    plain = _run(traffic, PipelineConfig(), lambda: ())
    assert [t for t, out in plain for c in out.alert_changes] == [alert_s]  # the same alert
    assert _spoofer_regions(plain)[0][0] >= alert_s


def test_a_strangers_region_wider_than_the_limit_is_kept_back_until_the_alert() -> None:
    traffic = make_traffic(Scene(seed=3, n_receivers=12, duration_s=40.0))
    narrow = PipelineConfig(tracks=TrackConfig(strangers_max_semi_axis_m=1.0))
    cycles = _run(traffic, narrow, lambda: {SPOOFER_ID})
    (alert_s,) = [t for t, out in cycles for c in out.alert_changes if c.state is AlertState.RAISED]
    tracked = [t for t, out in cycles if any(e.uas_id == SPOOFER_ID for e in out.tracks)]
    assert tracked[0] < alert_s  # tracked all along, its region kept back
    assert [t for t, _ in _spoofer_regions(cycles)] == [t for t, _ in cycles if t >= alert_s]


def test_a_strangers_track_ends_when_it_is_no_stranger_any_more() -> None:
    traffic = make_traffic(Scene(seed=1, n_receivers=10, duration_s=30.0))
    cfg = PipelineConfig(forced_alert=NO_ALERTS)
    now = [0.0]  # the cycle the pipeline asks in

    def strangers() -> set[str]:
        return {SPOOFER_ID} if now[0] < 20.0 else set()

    pipeline = EstimationPipeline(cfg, strangers=strangers)
    cycles = []
    for k in range(1, round(30.0 / CYCLE_S) + 1):
        now[0] = round(k * CYCLE_S, 6)
        cycles.append((now[0], pipeline.step(now[0], traffic.cycles.get(now[0], []))))
    assert not [c for _, out in cycles for c in out.alert_changes]
    regions = _spoofer_regions(cycles)
    assert regions and all(unconfirmed for _, unconfirmed in regions)
    assert max(t for t, _ in regions) == 19.75
    assert [t for t, out in cycles if SPOOFER_ID in out.deleted_tracks] == [20.0]


def test_a_silent_strangers_track_is_deleted_without_an_alert_to_clear() -> None:
    traffic = make_traffic(Scene(seed=2, n_receivers=10, duration_s=35.0))
    for t in list(traffic.cycles):  # the spoofer goes quiet after 20 s
        if t > 20.0:
            traffic.cycles[t] = [claim for claim in traffic.cycles[t] if claim.uas_id != SPOOFER_ID]
    cycles = _run(traffic, PipelineConfig(forced_alert=NO_ALERTS), lambda: {SPOOFER_ID})
    last_heard = max(
        claim.t_s for claims in traffic.cycles.values() for claim in claims
        if claim.uas_id == SPOOFER_ID
    )  # fmt: skip
    (deleted,) = [t for t, out in cycles if SPOOFER_ID in out.deleted_tracks]
    assert last_heard + 10.0 < deleted <= last_heard + 10.0 + CYCLE_S
    assert not [c for _, out in cycles for c in out.alert_changes]
    assert not any(out.regions for t, out in cycles if t >= deleted)


def test_a_silent_alerted_strangers_track_is_not_restarted_from_its_old_claims() -> None:
    # the alert cleared by the silence, the serial is still a stranger: what it said before
    # going quiet must not start a second track
    traffic = make_traffic(Scene(seed=2, n_receivers=10, duration_s=45.0))
    for t in list(traffic.cycles):
        if t > 20.0:
            traffic.cycles[t] = [claim for claim in traffic.cycles[t] if claim.uas_id != SPOOFER_ID]
    alert = ForcedAlertConfig(enabled=True, uas_id=SPOOFER_ID, time_s=5.0)
    cycles = _run(traffic, PipelineConfig(forced_alert=alert), lambda: {SPOOFER_ID})
    changes = [(c.state, t) for t, out in cycles for c in out.alert_changes]
    assert [state for state, _ in changes] == [AlertState.RAISED, AlertState.CLEARED]
    cleared_s = changes[1][1]
    assert [t for t, out in cycles if SPOOFER_ID in out.deleted_tracks] == [cleared_s]
    after = [e.uas_id for t, out in cycles if t >= cleared_s for e in out.tracks]
    assert SPOOFER_ID not in after


def test_the_calibrating_pipeline_tracks_the_labellers_strangers_from_the_configured_count() -> (
    None
):
    cfg = PipelineConfig(tracks=TrackConfig(strangers_after_claims=4))
    pipeline = CalibratingPipeline(cfg)
    lab = _labeller_after(5, [AWAY] * 5)
    pipeline.labeller = lab
    assert pipeline._strangers() == {"SPOOF"}
    off = CalibratingPipeline(PipelineConfig())
    off.labeller = lab
    assert off._strangers() == frozenset()


def test_strangers_need_the_labeller() -> None:
    with pytest.raises(FieldValueError, match=r"tracks\.strangers_after_claims"):
        PipelineConfig(
            tracks=TrackConfig(strangers_after_claims=3),
            calibration=CalibrationConfig(enabled=False),
        )


def test_a_negative_count_of_claims_is_refused() -> None:
    with pytest.raises(FieldValueError, match="strangers_after_claims"):
        TrackConfig(strangers_after_claims=-1)
