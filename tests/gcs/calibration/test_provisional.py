"""The provisional fit (``calibration.provisional_samples_per_parameter``): the estimation
pipeline starts before the full warm-up, and at the full warm-up it is replaced by one on the
full fit without losing an alert, a region or a track number."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ridsafe.common.errors import FieldValueError
from ridsafe.common.messages import AlertState
from ridsafe.common.pathloss import received_power_dbm
from ridsafe.gcs.calibration.config import CalibrationConfig
from ridsafe.gcs.calibration.pipeline import CalibratingPipeline
from ridsafe.gcs.pipeline_api import CycleOutput, ObservedClaim
from ridsafe.gcs.pipeline_config import PipelineConfig, TrackConfig
from tests.gcs.claims import free_space_claim, observed_claim

POSITIONS = {i: [150.0 * i - 500.0, 90.0 * (i % 3) - 90.0, 40.0 + 5.0 * i] for i in range(1, 7)}
LIAR = "LIAR"
LIAR_CLAIM_ENU_M = np.array([0.0, 0.0, 60.0])
LIAR_TRUE_ENU_M = np.array([250.0, 300.0, 60.0])
#: An honest transmitter outside the fleet, heard for 5 s: its track (a stranger's, from its
#: 5th claim) starts on the provisional fit, and none of its claims is in the 10 s replayed
#: at the switch, so nothing starts it again.
STRANGER = "STRANGER"
STRANGER_ENU_M = np.array([100.0, -200.0, 50.0])
STRANGER_HEARD_S = 5
#: 13 parameters (1 exponent, 6 biases, 6 levels), 30 labelled receptions a second: the
#: provisional fit after 2 s, the full one after 13 s.
CALIBRATION = CalibrationConfig(
    enabled=True,
    min_samples=1,
    min_time_s=0.0,
    samples_per_parameter=30.0,
    provisional_samples_per_parameter=3.0,
    provisional_min_samples=1,
)


def _heard_by_all(
    uas_id: str, t_s: float, claim_enu_m: np.ndarray, true_enu_m: np.ndarray
) -> ObservedClaim:
    """``uas_id`` claiming ``claim_enu_m``, heard by all six aircraft as a 20 dBm
    transmitter at ``true_enu_m`` (noise-free free space)."""
    rx_ids = np.array(sorted(POSITIONS), dtype=np.int64)
    rx_enu_m = np.array([POSITIONS[i] for i in sorted(POSITIONS)])
    rssi = received_power_dbm(20.0, np.linalg.norm(rx_enu_m - true_enu_m, axis=1))
    return observed_claim(uas_id, t_s, claim_enu_m, rx_enu_m, rssi, rx_ids)


def _cycle_claims(t_s: float) -> list[ObservedClaim]:
    """Every aircraft heard by the others (noise-free free space), and the liar, 300 m from
    its claim, heard by all six."""
    claims = [
        free_space_claim(f"RID{i}", t_s, p, {j: q for j, q in POSITIONS.items() if j != i})
        for i, p in POSITIONS.items()
    ]
    claims.append(_heard_by_all(LIAR, t_s, LIAR_CLAIM_ENU_M, LIAR_TRUE_ENU_M))
    return claims


def _fly(
    calibration: CalibrationConfig, seconds: int, config: PipelineConfig | None = None
) -> list[tuple[float, CycleOutput, bool]]:
    """Each cycle's output and whether the pipeline was then on its provisional fit; a
    stranger telling the truth is heard in the first ``STRANGER_HEARD_S`` seconds."""
    config = PipelineConfig() if config is None else config
    pipeline = CalibratingPipeline(dataclasses.replace(config, calibration=calibration))
    cycles = []
    for k in range(seconds):
        claims = _cycle_claims(float(k))
        if k < STRANGER_HEARD_S:
            claims.append(_heard_by_all(STRANGER, float(k), STRANGER_ENU_M, STRANGER_ENU_M))
        out = pipeline.step(k + 0.25, claims)
        cycles.append((k + 0.25, out, pipeline.provisional))
    return cycles


def test_an_alert_raised_on_the_provisional_fit_outlives_the_switch() -> None:
    cycles = _fly(CALIBRATION, 25)
    decisions = [(t, out.channel) for t, out, _ in cycles if out.channel is not None]
    assert [d.channel for _, d in decisions] == ["provisional", "fitted"]
    (provisional_s, provisional), (fitted_s, fitted) = decisions
    assert 3 * 13 <= provisional.n_samples < 30 * 13 <= fitted.n_samples
    raised = [
        (t, c) for t, out, _ in cycles for c in out.alert_changes if c.state is AlertState.RAISED
    ]
    assert [c.uas_id for _, c in raised] == [LIAR]  # once, and never again after the switch
    assert provisional_s <= raised[0][0] < fitted_s
    # The liar's region goes out every cycle from its alert on, the switch's included, and
    # its track after the switch has a number of its own.
    region_tracks = [
        (t, r.track_id) for t, out, _ in cycles for r in out.regions if r.uas_id == LIAR
    ]
    region_s = [t for t, _ in region_tracks]
    assert region_s == [t for t, _, _ in cycles if t >= region_s[0]]
    assert region_s[0] <= raised[0][0] + 1.0
    before = {n for t, n in region_tracks if t < fitted_s}
    after = {n for t, n in region_tracks if t >= fitted_s}
    assert before and after and not before & after
    assert not any(LIAR in out.deleted_tracks for _, out, _ in cycles)
    assert not any(p for t, _, p in cycles if t >= fitted_s)


def test_without_a_provisional_stage_nothing_runs_before_the_full_warm_up() -> None:
    no_stage = CalibrationConfig(
        enabled=True, min_samples=1, min_time_s=0.0, samples_per_parameter=30.0
    )
    cycles = _fly(no_stage, 25)
    decisions = [(t, out.channel) for t, out, _ in cycles if out.channel is not None]
    assert [d.channel for _, d in decisions] == ["fitted"]
    fitted_s = decisions[0][0]
    assert not any(out.regions or out.alert_changes for t, out, _ in cycles if t < fitted_s)
    assert not any(p for _, _, p in cycles)


def test_a_negative_provisional_count_is_an_error() -> None:
    with pytest.raises(FieldValueError, match="provisional_samples_per_parameter"):
        CalibrationConfig(provisional_samples_per_parameter=-1.0)
    with pytest.raises(FieldValueError, match="provisional_min_samples"):
        CalibrationConfig(provisional_min_samples=0)


def test_a_track_the_full_fit_does_not_start_again_is_reported_ended() -> None:
    """The stranger's track, started on the provisional fit, is not started again from the
    replayed claims: the switch's output deletes it, so its region does not linger."""
    tracks = TrackConfig(strangers_after_claims=5, silence_timeout_s=30.0)  # not by silence
    strangers = PipelineConfig(tracks=tracks)
    cycles = _fly(CALIBRATION, 20, strangers)
    (fitted_s,) = [t for t, out, _ in cycles if out.channel and out.channel.channel == "fitted"]
    tracked_s = [t for t, out, _ in cycles for e in out.tracks if e.uas_id == STRANGER]
    assert tracked_s and max(tracked_s) < fitted_s
    deleted_s = [t for t, out, _ in cycles if STRANGER in out.deleted_tracks]
    assert deleted_s == [fitted_s]


def test_with_provisional_keeps_tracks_the_liar_s_track_goes_on_through_the_switch() -> None:
    """The track started on the provisional fit goes on in the full fit's pipeline under its
    number, and takes each of the liar's claims once: the held claims replayed at the switch
    are not given to it again."""
    keep = dataclasses.replace(CALIBRATION, provisional_keeps_tracks=True)
    config = dataclasses.replace(PipelineConfig(), calibration=keep)
    pipeline = CalibratingPipeline(config)
    track_ids: list[tuple[float, int]] = []
    switch_s = None
    for k in range(25):
        was_provisional = pipeline.provisional
        out = pipeline.step(k + 0.25, _cycle_claims(float(k)))
        if was_provisional and not pipeline.provisional:
            switch_s = k + 0.25
        track_ids += [(k + 0.25, r.track_id) for r in out.regions if r.uas_id == LIAR]
    assert switch_s is not None
    before = {n for t, n in track_ids if t < switch_s}
    after = {n for t, n in track_ids if t >= switch_s}
    assert before and before == after  # one track, one number
    assert pipeline.inner is not None
    track = pipeline.inner.tracks[LIAR]
    # At most one update per claim from its start on (the start counts as one; claims at
    # whole seconds, the last at 24 s).
    assert track.created_s < switch_s - 1.0
    assert 0 < track.n_updates <= 25 - track.created_s
