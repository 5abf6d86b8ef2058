"""The GCS estimation pipeline: detection -> initiation -> localisation -> tracking -> region.

It composes the concepts, each in its own package: ``detection/`` (spoofing detectors, and
the registry of those that run), ``initiation/`` (where a track starts), ``localisation/``
(estimators, and the registry ``pipeline.estimator`` picks from), ``tracking/`` (motion
models and the IMM), ``region/`` (the chance-constrained ellipsoid); ``tracks.py`` is a
track's life.

``EstimationPipeline.step(now_s, claims)`` (the ``GcsPipeline`` protocol of
``pipeline_api.py``) is called every GCS cycle (0.25 s) with the observed claims that closed
since the last cycle, and answers what it decided. Each cycle:

0. at most ``max_claims_per_cycle`` claims run, or more when the waiting ones could not
   otherwise all run within ``max_claim_wait_s`` of arriving at that many per cycle (the
   least even rate that meets every claim's wait); the claims of suspects (alerted, new, or
   scoring above ``SUSPICION`` of a threshold) and those that waited ``max_claim_wait_s``
   always run; the rest wait for the next cycles, oldest first; a claim that updates a track
   counts as ``track_claim_cost`` claims, so a cycle with a track update takes fewer waiting
   ones, and the even rate is over the cycles no track update is expected in (a tracked
   transmitter's next claim one period after its last): a second's aligned broadcasts of 64
   aircraft, with the spoofer's claim in a cycle of its own, run as 22, 21, the track, 21
   (without the expectation: 17, 17, the track, and the 30 left at the wait limit);
1. every claim (in time order) goes through its claimed transmitter's detectors
   (a ``TransmitterMonitor`` per uas_id heard, benign ones too; all of a cycle's claims in
   one batch, ``detection.monitor.observe_batch``) -> ``DetectorResult``s;
   it is kept ``max(backfill_s, window_s)`` seconds for track initiation, and updates the
   uas_id's track if there is one;
2. alerts: the first decision of an alerting detector (``detection.alerting``) raises the
   uas_id's alert, once; with ``forced_alert.enabled`` the configured uas_id is raised with
   detector FORCED at ``time_s`` (and the real detectors only report unless
   ``detectors_also_alert``);
3. every alerted uas_id without a track gets one from its recent claims, and so does every
   *stranger* (``tracks.strangers_after_claims``; the serials the caller's ``strangers``
   names: no cooperative aircraft accounts for them), its region flagged ``unconfirmed``
   while no alert stands and published only while no wider than
   ``tracks.strangers_max_semi_axis_m``; a stranger's track ends once it is neither a
   stranger nor alerted;
4. a track whose transmitter was silent ``silence_timeout_s`` is deleted and its alert
   CLEARED (an alert latches while the transmitter is heard: a spoofer that turns honest
   keeps its region until it goes quiet; after a clear, new evidence raises it again); with
   ``tracks.coast_max_radius_m`` > 0 it coasts on, its prediction's covariance growing, until
   its region is wider than that;
5. every live track is predicted to ``now_s`` -> ``TrackEstimate`` and ``UnsafeRegion`` (as
   ``region/publishing.py`` publishes it: the estimate itself unless configured); with
   ``ghosts.enabled`` a track that stands still while its claim flies is a radio on the
   ground, its region flat on it (``region/ground.py``).

The compute time of each cycle is logged (DEBUG) and kept in ``compute_s``. The matrices are
tiny: run the GCS with ``OPENBLAS_NUM_THREADS=1`` (set before numpy is imported); BLAS worker
threads only add latency, and on a loaded two-core machine a call waiting for a preempted
worker stalls a whole scheduler tick (4 ms), which is what the p99 then shows.
"""

from __future__ import annotations

import logging
import math
import time
from collections import deque
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass

import numpy as np

from ridsafe.common.messages import AlertState, RidsafeDetector
from ridsafe.common.pathloss import received_power_dbm
from ridsafe.gcs.detection.monitor import TransmitterMonitor, observe_batch
from ridsafe.gcs.localisation import mixture_kernels
from ridsafe.gcs.pipeline_api import (
    FORGET_AFTER_S,
    AlertChange,
    CycleOutput,
    DetectorResult,
    ObservedClaim,
    TrackEstimate,
    UnsafeRegion,
    airborne_receptions,
    for_tracks,
    readonly,
)
from ridsafe.gcs.pipeline_config import PipelineConfig, TrackConfig
from ridsafe.gcs.pipeline_kernels import all_finite
from ridsafe.gcs.region.ground import GroundWatch, flat_on_ground
from ridsafe.gcs.region.publishing import RegionPublisher
from ridsafe.gcs.region.unsafe_region import chi2_threshold, make_region
from ridsafe.gcs.tracks import Track, finite, initiate

logger = logging.getLogger(__name__)

__all__ = ["EstimationPipeline"]

_EPS_S = 1e-9
#: With ``max_claims_per_cycle``, a transmitter whose latest claim scored above this fraction
#: of an alerting detector's threshold never waits (nor a new or alerted one).
SUSPICION = 0.5
#: How many cycles' compute times are kept for ``compute_s``.
COMPUTE_HISTORY = 100_000


@dataclass
class _Alert:
    detector: RidsafeDetector
    raised_s: float


@dataclass
class _Heard:
    """One claimed transmitter: its detectors and its recent claims."""

    monitor: TransmitterMonitor
    recent: deque[ObservedClaim]
    last_heard_s: float
    tried_init_at_s: float = -float("inf")  # newest claim a track start has seen
    suspicious: bool = True  # until its first tested claim says otherwise


def warm_up() -> None:
    """Load (or compile) every numba kernel once, so no cycle of a run pays for it: one
    small claim through detection, a track start and an update. Receiver ids come
    read-only (as from ``ingest``) and writable (as from tests): numba compiles each."""
    rx = np.array([[0.0, 0.0, 50.0], [400.0, 0.0, 80.0], [0.0, 400.0, 40.0], [400.0, 400, 60]])
    p = np.array([150.0, 250.0, 60.0])
    rssi = received_power_dbm(20.0, np.linalg.norm(rx - p, axis=1))
    sysids = np.arange(1, 5, dtype=np.int64)
    frozen_sysids = sysids.copy()
    frozen_sysids.setflags(write=False)
    claims = [
        ObservedClaim(
            "warm-up",
            t,
            readonly(p),
            None,
            ids,
            readonly(rx),
            readonly(np.full(4, t)),
            readonly(rssi),
        )
        for t, ids in ((0.0, sysids), (1.0, frozen_sysids), (2.0, sysids))
    ]
    cfg = PipelineConfig(tracks=TrackConfig(max_init_std_m=0.0))
    monitor = TransmitterMonitor("warm-up", cfg)
    for claim in claims:
        _finite(claim)
        monitor.observe(claim)
    track = initiate("warm-up", 0, claims[:2], cfg)
    if track is not None:
        track.update(claims[2])
    # What a small start may not reach: the split test and the pairwise merge distances.
    x, P = np.zeros((2, 7)), np.tile(np.eye(7), (2, 1, 1))
    mixture_kernels.split_curvature(x, P, rx.copy())
    mixture_kernels.pair_mahalanobis2(x[:, :3].copy(), P[:, :3, :3].copy())


def _claim_time(item: tuple[float, ObservedClaim]) -> float:
    return item[1].t_s


def _finite(claim: ObservedClaim) -> bool:
    return bool(
        all_finite(
            np.ascontiguousarray(claim.claimed_p_enu_m),
            np.ascontiguousarray(claim.rx_p_enu_m),
            np.ascontiguousarray(claim.rssi_dbm),
            np.ascontiguousarray(claim.rx_t_s),
        )
    )


#: (claim, its detectors' results) -> the results alerts are decided on
ResultReview = Callable[[ObservedClaim, tuple[DetectorResult, ...]], tuple[DetectorResult, ...]]
#: () -> the serials to track before any alert (strangers: ``tracks.strangers_after_claims``)
Strangers = Callable[[], Collection[str]]


class EstimationPipeline:
    """Sans-I/O: state lives here, time comes in as ``now_s``, nothing reads a clock except
    the compute-time measurement. The first construction in a process warms the compiled
    kernels up (``warm_up``)."""

    _warm = False

    def __init__(
        self,
        config: PipelineConfig | None = None,
        review: ResultReview | None = None,
        strangers: Strangers | None = None,
    ) -> None:
        """``review(claim, results)``: the results the alerts are decided on (default: the
        detectors' own), e.g. the calibration's (``calibration/review.py``); ``strangers()``:
        the serials tracked before any alert, asked every cycle (default: none)."""
        self._review = review
        self._strangers = strangers
        EstimationPipeline.ensure_warm()
        self.config = config if config is not None else PipelineConfig()
        self._heard: dict[str, _Heard] = {}
        self._alerts: dict[str, _Alert] = {}
        self._tracks: dict[str, Track] = {}
        self._next_track_id = 1
        self._forced_done = False
        self._publisher = RegionPublisher(self.config.region.publish)
        ghosts, ground_z_m = self.config.ghosts, self.config.rssi_filter.ground_z_enu_m
        self._ground = (
            GroundWatch(ghosts, ground_z_m) if ghosts.enabled and ground_z_m is not None else None
        )
        self._waiting: list[tuple[float, ObservedClaim]] = []  # (arrived s, claim)
        # per tracked uas_id: the cycles its last two claims arrived in (s; None: one so far)
        self._track_arrivals: dict[str, tuple[float | None, float]] = {}
        #: Tracks taken over from a replaced pipeline: the newest claim each had taken.
        self._taken_until_s: dict[str, float] = {}
        self._last_step_s: float | None = None
        self.compute_s: deque[float] = deque(maxlen=COMPUTE_HISTORY)

    @classmethod
    def ensure_warm(cls) -> None:
        """Warm the kernels up once per process (``warm_up``): a pipeline that builds this
        one later in a run (``calibration/pipeline.py``) calls it when it is built itself."""
        if not cls._warm:
            warm_up()
            cls._warm = True

    def take_over(self, previous: EstimationPipeline, keep_tracks: bool = False) -> None:
        """Continue ``previous``, which this (new, not yet stepped) pipeline replaces on
        another channel (``calibration/pipeline.py``): its alerts stand (not raised again),
        its track numbers are not reused, and its compute times are kept. Its tracks start
        afresh from the claims this one is given, or with ``keep_tracks`` go on here, each
        given only the claims after the last it took."""
        self._alerts = dict(previous._alerts)
        self._next_track_id = previous._next_track_id
        self._forced_done = previous._forced_done
        self.compute_s.extend(previous.compute_s)
        if keep_tracks:
            self._tracks = dict(previous._tracks)
            self._track_arrivals = dict(previous._track_arrivals)
            self._taken_until_s = {u: t.last_heard_s for u, t in previous._tracks.items()}

    def _not_yet_taken(self, claim: ObservedClaim) -> bool:
        """Whether a track taken over from a replaced pipeline has not yet had ``claim``
        (every claim of any other track is new)."""
        taken_s = self._taken_until_s.get(claim.uas_id)
        return taken_s is None or claim.t_s > taken_s

    # --- the GcsPipeline protocol ---------------------------------------------------------

    def step(self, now_s: float, claims: Sequence[ObservedClaim]) -> CycleOutput:
        start = time.perf_counter()
        for track in self._tracks.values():
            track.fixed_this_cycle = False
        results: list[tuple[DetectorResult, ...]] = []
        changes: list[AlertChange] = []
        usable = [c for c in self._admit(now_s, claims) if self._usable(c)]
        for claim, detected in zip(usable, self._detect(usable), strict=True):
            claim_results = detected if self._review is None else self._review(claim, detected)
            results.append(claim_results)
            self._note_suspicion(claim.uas_id, claim_results)
            changes.extend(self._maybe_raise(claim.uas_id, claim.t_s, claim_results))
            live = self._tracks.get(claim.uas_id)
            if live is not None and self._not_yet_taken(claim):
                heard_up = self._for_tracks(claim)
                if heard_up.n_receivers:
                    live.update(heard_up)
        changes.extend(self._forced(now_s))
        to_track = self._to_track()
        self._initiate_tracks(to_track)
        deleted, cleared = self._delete_silent(now_s)
        deleted.extend(self._end_unconfirmed(set(to_track)))
        changes.extend(cleared)
        out = self._outputs(now_s, results, changes, deleted)
        elapsed = time.perf_counter() - start
        self.compute_s.append(elapsed)
        logger.debug(
            "gcs cycle t=%.2f s: %d claims, %d tracks, compute %.3f ms",
            now_s,
            len(claims),
            len(self._tracks),
            elapsed * 1e3,
        )
        return out

    # --- which claims run now ---------------------------------------------------------------

    def _admit(self, now_s: float, claims: Sequence[ObservedClaim]) -> list[ObservedClaim]:
        """This cycle's claims in time order: the new ones and those that waited, at most
        ``_budget`` besides the suspects' and those waiting ``max_claim_wait_s`` already;
        the rest wait (oldest first, so one transmitter's claims keep their order)."""
        cycle_s = None if self._last_step_s is None else now_s - self._last_step_s
        self._last_step_s = now_s
        self._note_track_arrivals(now_s, claims)
        waiting = sorted([*self._waiting, *((now_s, c) for c in claims)], key=_claim_time)
        limit = self.config.max_claims_per_cycle
        if limit <= 0 or len(waiting) <= limit:
            self._waiting = []
            return [claim for _, claim in waiting]
        due_s = now_s - self.config.max_claim_wait_s
        must: list[tuple[float, ObservedClaim]] = []
        may: list[tuple[float, ObservedClaim]] = []
        for item in waiting:
            arrived_s, claim = item
            urgent = arrived_s <= due_s + _EPS_S or self._suspect(claim.uas_id)
            (must if urgent else may).append(item)
        extra = sum(self._track_extra(claim) for _, claim in must)
        budget = self._budget(now_s, cycle_s, len(must), may, track_now=extra > 0)
        room = max(0, budget - len(must) - extra)
        self._waiting = may[room:]
        return [claim for _, claim in sorted([*must, *may[:room]], key=_claim_time)]

    def _budget(
        self,
        now_s: float,
        cycle_s: float | None,
        n_must: int,
        may: Sequence[tuple[float, ObservedClaim]],
        track_now: bool = False,
    ) -> int:
        """Claims to run this cycle: ``max_claims_per_cycle``, or the least constant number
        per cycle that runs every waiting claim within ``max_claim_wait_s`` of its arrival
        (cycles of ``cycle_s``, the time since the last step) if that is more. A cycle that
        updates a track spends ``track_claim_cost`` of its budget on it: this one if
        ``track_now``, and each later one a track's next claim is expected in
        (``_expected_track_cycles``). The budget is the least that runs the waiting claims
        in time with those cycles taking ``budget - track_claim_cost`` each (none while the
        others can take all), so one track's cycle leaves them to the other cycles and with a
        track in every cycle they spread over all of them alike."""
        limit = self.config.max_claims_per_cycle
        if cycle_s is None or cycle_s <= 0.0:
            return limit
        wait_s = self.config.max_claim_wait_s
        cost = self.config.track_claim_cost
        expected = self._expected_track_cycles(now_s, cycle_s) if cost > 1 else []
        need, queued = 0, n_must
        for arrived_s in sorted(arrived for arrived, _ in may):
            queued += 1
            deadline_s = arrived_s + wait_s
            cycles = max(1, 1 + math.floor((deadline_s - now_s) / cycle_s + 1e-6))
            taken = min(cycles, int(track_now) + sum(t <= deadline_s + _EPS_S for t in expected))
            free = cycles - taken
            if free > 0 and math.ceil(queued / free) <= cost:
                need = max(need, math.ceil(queued / free))
            else:  # every cycle busy: each runs the same work, a track's counted as its cost
                need = max(need, math.ceil((queued + taken * cost) / cycles))
        return max(limit, need)

    def _note_track_arrivals(self, now_s: float, claims: Sequence[ObservedClaim]) -> None:
        """Remember the cycle each tracked transmitter's claims arrive in (once a cycle)."""
        for uas_id in {c.uas_id for c in claims if c.uas_id in self._tracks}:
            previous = self._track_arrivals.get(uas_id)
            if previous is None or previous[1] < now_s - _EPS_S:
                self._track_arrivals[uas_id] = (None if previous is None else previous[1], now_s)

    def _expected_track_cycles(self, now_s: float, cycle_s: float) -> list[float]:
        """The later cycles (s, on this cycle's grid) a live track's next claim is expected
        in: a transmitter broadcasts periodically, so one period (its last two claims'
        spacing) after its last; distinct cycles only."""
        cycles: set[float] = set()
        for before_s, last_s in self._track_arrivals.values():
            if before_s is None:
                continue
            next_s = last_s + (last_s - before_s)
            steps = math.ceil((next_s - now_s) / cycle_s - 1e-6)
            if steps >= 1:
                cycles.add(round(now_s + steps * cycle_s, 6))
        return sorted(cycles)

    def _track_extra(self, claim: ObservedClaim) -> int:
        """What a claim costs beyond one claim's detection: its track's update, if any."""
        return self.config.track_claim_cost - 1 if claim.uas_id in self._tracks else 0

    def _suspect(self, uas_id: str) -> bool:
        """Alerted, never tested, or its latest test at ``SUSPICION`` of a threshold."""
        heard = self._heard.get(uas_id)
        return uas_id in self._alerts or uas_id in self._tracks or heard is None or heard.suspicious

    def _note_suspicion(self, uas_id: str, results: Sequence[DetectorResult]) -> None:
        if not results or self.config.max_claims_per_cycle <= 0:
            return
        alerting = self.config.detection.alerting
        self._heard[uas_id].suspicious = any(
            r.statistic > SUSPICION * r.threshold for r in results if r.detector in alerting
        )

    @property
    def waiting(self) -> tuple[ObservedClaim, ...]:
        """Claims left for the next cycles (``max_claims_per_cycle``), oldest first."""
        return tuple(claim for _, claim in self._waiting)

    # --- detection and alerts -------------------------------------------------------------

    @staticmethod
    def _usable(claim: ObservedClaim) -> bool:
        if _finite(claim):
            return True
        logger.warning("claim of %s with non-finite values ignored", claim.uas_id)
        return False

    def _detect(self, claims: Sequence[ObservedClaim]) -> list[tuple[DetectorResult, ...]]:
        """Remember each claim for its transmitter and run its detectors: every claim of the
        cycle through one batch (``detection.monitor.observe_batch``); detection never
        depends on the tracks, so it may run before the cycle's track updates."""
        cfg = self.config
        keep_s = cfg.claims_kept_s
        monitors = []
        for claim in claims:
            heard = self._heard.get(claim.uas_id)
            if heard is None:
                monitor = TransmitterMonitor(claim.uas_id, cfg)
                heard = self._heard[claim.uas_id] = _Heard(monitor, deque(), claim.t_s)
            heard.last_heard_s = max(heard.last_heard_s, claim.t_s)
            heard.recent.append(claim)
            while heard.recent and heard.recent[0].t_s < claim.t_s - keep_s:
                heard.recent.popleft()
            monitors.append(heard.monitor)
        return observe_batch(monitors, claims)

    def _detectors_may_alert(self) -> bool:
        forced = self.config.forced_alert
        return not forced.enabled or forced.detectors_also_alert

    def _maybe_raise(
        self, uas_id: str, t_s: float, results: Sequence[DetectorResult]
    ) -> list[AlertChange]:
        if uas_id in self._alerts or not self._detectors_may_alert():
            return []
        if not any(r.decision for r in results):
            return []  # the usual case: no detector decided
        by_detector = {r.detector: r for r in results}
        for det in self.config.detection.alerting:
            r = by_detector.get(det)
            if r is not None and r.decision:
                self._alerts[uas_id] = _Alert(det, t_s)
                logger.info("alert raised on %s by %s at %.2f s", uas_id, det.name, t_s)
                return [AlertChange(uas_id, det, r.statistic, r.threshold, AlertState.RAISED)]
        return []

    def _forced(self, now_s: float) -> list[AlertChange]:
        forced = self.config.forced_alert
        if not forced.enabled or self._forced_done or now_s < forced.time_s:
            return []
        self._forced_done = True
        if forced.uas_id in self._alerts:
            return []
        self._alerts[forced.uas_id] = _Alert(RidsafeDetector.FORCED, now_s)
        logger.info("forced alert on %s at %.2f s", forced.uas_id, now_s)
        # A forced alert has no test: statistic 1 over threshold 0.
        return [AlertChange(forced.uas_id, RidsafeDetector.FORCED, 1.0, 0.0, AlertState.RAISED)]

    # --- tracks ---------------------------------------------------------------------------

    def _to_track(self) -> list[str]:
        """The alerted serials, then the strangers not alerted."""
        strangers = () if self._strangers is None else self._strangers()
        return [*self._alerts, *(s for s in sorted(strangers) if s not in self._alerts)]

    def _initiate_tracks(self, to_track: Sequence[str]) -> None:
        for uas_id in to_track:
            if uas_id in self._tracks:
                continue
            heard = self._heard.get(uas_id)
            if heard is None or not heard.recent or heard.recent[-1].t_s <= heard.tried_init_at_s:
                continue
            tried = heard.tried_init_at_s
            heard.tried_init_at_s = heard.recent[-1].t_s
            history = [self._for_tracks(claim) for claim in heard.recent]
            track = initiate(uas_id, self._next_track_id, history, self.config, tried)
            if track is not None:
                self._tracks[uas_id] = track
                self._next_track_id += 1
                logger.info("track %d started on %s", track.track_id, uas_id)

    def _for_tracks(self, claim: ObservedClaim) -> ObservedClaim:
        """The claim's receptions a track uses (``tracks.min_receiver_height_m``)."""
        return for_tracks(airborne_receptions(claim, self.config.tracks.min_receiver_height_m))

    def _delete_silent(self, now_s: float) -> tuple[list[str], list[AlertChange]]:
        timeout = self.config.tracks.silence_timeout_s
        deleted: list[str] = []
        cleared: list[AlertChange] = []
        for uas_id, alert in list(self._alerts.items()):
            heard = self._heard.get(uas_id)
            last = max(alert.raised_s, heard.last_heard_s if heard else -float("inf"))
            if now_s - last <= timeout or self._coasting(uas_id, now_s, now_s - last):
                continue
            del self._alerts[uas_id]
            cleared.append(AlertChange(uas_id, alert.detector, 0.0, 0.0, AlertState.CLEARED))
            if self._end_track(uas_id):
                deleted.append(uas_id)
                logger.info("track on %s deleted after %.1f s of silence", uas_id, timeout)
        for uas_id in [u for u in self._tracks if u not in self._alerts]:  # strangers'
            heard = self._heard.get(uas_id)
            if heard is None or now_s - heard.last_heard_s > timeout:
                self._end_track(uas_id)
                deleted.append(uas_id)
                logger.info("track on stranger %s deleted after %.1f s of silence", uas_id, timeout)
        for uas_id, heard in list(self._heard.items()):
            if now_s - heard.last_heard_s > FORGET_AFTER_S and uas_id not in self._alerts:
                del self._heard[uas_id]
        return deleted, cleared

    def _end_unconfirmed(self, to_track: set[str]) -> list[str]:
        """End the tracks of serials neither alerted nor strangers any longer."""
        return [u for u in list(self._tracks) if u not in to_track and self._end_track(u)]

    def _end_track(self, uas_id: str) -> bool:
        """Forget ``uas_id``'s track (a new one needs a newer claim); False if it had none."""
        if self._tracks.pop(uas_id, None) is None:
            return False
        heard = self._heard.get(uas_id)
        if heard is not None and heard.recent:
            heard.tried_init_at_s = heard.recent[-1].t_s
        self._track_arrivals.pop(uas_id, None)
        self._publisher.forget(uas_id)
        if self._ground is not None:
            self._ground.forget(uas_id)
        return True

    def _coasting(self, uas_id: str, now_s: float, silent_s: float) -> bool:
        """Keep a silent alerted track while its region is narrow enough (``tracks.
        coast_max_radius_m``; 0: never past ``silence_timeout_s``)."""
        limit_m = self.config.tracks.coast_max_radius_m
        track = self._tracks.get(uas_id)
        if limit_m <= 0.0 or track is None or silent_s > FORGET_AFTER_S:
            return False
        est = track.estimate(now_s)
        if not finite(est):
            return False
        region = make_region(
            uas_id, est.track_id, now_s, est.p_enu_m, est.cov_enu_m2, est.v_enu_m_s,
            self.config.region,
        )  # fmt: skip
        return float(np.max(region.semi_axes_m)) <= limit_m

    def _outputs(
        self,
        now_s: float,
        results: list[tuple[DetectorResult, ...]],
        changes: list[AlertChange],
        deleted: list[str],
    ) -> CycleOutput:
        estimates = []
        regions: list[UnsafeRegion] = []
        wide_m = self.config.tracks.strangers_max_semi_axis_m
        for track in self._tracks.values():
            est = track.estimate(now_s)
            if not finite(est):
                logger.warning("track %d on %s is not finite: skipped", track.track_id, est.uas_id)
                continue
            estimates.append(est)
            center, cov = self._publisher.publish(est.uas_id, est.p_enu_m, est.cov_enu_m2)
            velocity, on_ground, ground = est.v_enu_m_s, False, self._ground
            if ground is not None and self._on_ground(ground, now_s, est):
                on_ground, velocity = True, np.zeros(3)
                center, cov = flat_on_ground(
                    center, cov, ground.ground_z_enu_m, self.config.ghosts.max_height_m,
                    chi2_threshold(self.config.region.alpha),
                )  # fmt: skip
            region = make_region(
                est.uas_id,
                est.track_id,
                now_s,
                center,
                cov,
                velocity,
                self.config.region,
                on_ground,
                unconfirmed=est.uas_id not in self._alerts,
            )
            if not region.unconfirmed or region.semi_axes_m[0] <= wide_m:
                regions.append(region)
        return CycleOutput(
            claim_results=tuple(results),
            alert_changes=tuple(changes),
            tracks=tuple(estimates),
            regions=tuple(regions),
            deleted_tracks=tuple(deleted),
        )

    def _on_ground(self, ground: GroundWatch, now_s: float, est: TrackEstimate) -> bool:
        """Is the track's transmitter a radio on the ground (``region/ground.py``)?"""
        heard = self._heard.get(est.uas_id)
        if heard is None or not heard.recent:
            return False
        claim = heard.recent[-1].claimed_p_enu_m
        return ground.update(est.uas_id, now_s, est.p_enu_m, est.cov_enu_m2, est.v_enu_m_s, claim)

    # --- introspection --------------------------------------------------------------------

    @property
    def alerted(self) -> frozenset[str]:
        return frozenset(self._alerts)

    @property
    def tracks(self) -> dict[str, Track]:
        return dict(self._tracks)
