"""Which claimed transmitters are the GCS's own cooperative aircraft, and their receptions.

The GCS does not know which RID serial each companion flies. It does know where each
receiver (by system id) says it is, from the observation reports. A claim whose position
lies within ``match_m`` of exactly one receiver's recent own position, and that receiver is
not among those that heard it (nobody hears itself), is that aircraft's; a serial is
labelled cooperative once its matches agree (``min_matches``, at most
``max_mismatch_fraction`` elsewhere). Each later claim of a labelled serial that still
matches its receiver yields labelled receptions: (transmitter, receiver, distance, RSSI).
A spoofer's claims sit far from where any receiver is, so they are never labelled; to poison
the fit it would have to claim a benign aircraft's true position, and then it is harmless.
"""

from __future__ import annotations

from collections import Counter, OrderedDict
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ridsafe.gcs.calibration.config import CalibrationConfig
from ridsafe.gcs.calibration.cooperative_kernels import update_and_match
from ridsafe.gcs.pipeline_api import (
    FORGET_AFTER_S,
    ObservedClaim,
    airborne_receptions,
    claimed_positions,
    reception_bounds,
    receptions,
)

FloatArray = NDArray[np.float64]

__all__ = ["CooperativeLabeller", "LabelledReceptions", "claim_links", "link_elevation_deg"]


class LabelledReceptions:
    """The newest ``max_samples`` labelled receptions, as columns (a ring buffer: the
    oldest overwritten; order is not kept, the fit and the check need none)."""

    def __init__(self, max_samples: int) -> None:
        self.max_samples = max_samples
        self._tx = np.zeros(max_samples, dtype=np.int64)
        self._rx = np.zeros(max_samples, dtype=np.int64)
        self._distance_m = np.zeros(max_samples)
        self._rssi_dbm = np.zeros(max_samples)
        self._elevation_deg = np.zeros(max_samples)
        self._next = 0  # where the next reception goes
        self._count = 0

    def __len__(self) -> int:
        return self._count

    @property
    def tx_sysid(self) -> NDArray[np.int64]:
        return self._tx[: self._count]

    @property
    def rx_sysid(self) -> NDArray[np.int64]:
        return self._rx[: self._count]

    @property
    def distance_m(self) -> FloatArray:
        return self._distance_m[: self._count]

    @property
    def rssi_dbm(self) -> FloatArray:
        return self._rssi_dbm[: self._count]

    @property
    def elevation_deg(self) -> FloatArray:
        """The link's elevation, |asin(dz / d)| (degrees, 0 level, 90 straight up or down)."""
        return self._elevation_deg[: self._count]

    def n_parameters(self) -> int:
        """Parameters a channel fit of these receptions has (``channel_fit.py``): the
        exponent, a bias per receiver and a level per transmitter."""
        n_rx, n_tx = np.unique(self.rx_sysid).shape[0], np.unique(self.tx_sysid).shape[0]
        return 1 + int(n_rx) + int(n_tx)

    def add(
        self,
        tx: int,
        rx: NDArray[np.int64],
        distance_m: FloatArray,
        rssi: FloatArray,
        elevation_deg: FloatArray | None = None,
    ) -> None:
        """One transmitter's receptions (the newest ``max_samples`` of them); level links
        unless ``elevation_deg`` says otherwise."""
        newest = slice(max(rx.shape[0] - self.max_samples, 0), None)
        tx_column = np.full(rx[newest].shape[0], tx, dtype=np.int64)
        if elevation_deg is None:
            elevation_deg = np.zeros(rx.shape[0])
        self.add_rows(
            tx_column, rx[newest], distance_m[newest], rssi[newest], elevation_deg[newest]
        )

    def add_claims(self, labelled: Sequence[tuple[int, ObservedClaim]]) -> None:
        """``add`` the receptions of each (transmitter, claim) in order, the distance from
        each receiver to the claimed position; one write for them all where they fit the
        buffer (the same rows, in the same order, as one ``add`` per claim)."""
        if not labelled:
            return
        claims = [claim for _, claim in labelled]
        counts = [claim.n_receivers for claim in claims]
        if sum(counts) > self.max_samples:
            for tx, claim in labelled:
                distance_m, elevation_deg = claim_links([claim])
                self.add(tx, claim.rx_sysid, distance_m, claim.rssi_dbm, elevation_deg)
            return
        distance_m, elevation_deg = claim_links(claims)
        self.add_rows(
            np.repeat(np.array([tx for tx, _ in labelled], dtype=np.int64), counts),
            np.concatenate([claim.rx_sysid for claim in claims]),
            distance_m,
            np.concatenate([claim.rssi_dbm for claim in claims]),
            elevation_deg,
        )

    def add_rows(
        self,
        tx: NDArray[np.int64],
        rx: NDArray[np.int64],
        distance_m: FloatArray,
        rssi: FloatArray,
        elevation_deg: FloatArray | None = None,
    ) -> None:
        """Receptions as columns, at most ``max_samples`` of them, written in order from the
        next free row (wrapping)."""
        k = rx.shape[0]
        if elevation_deg is None:
            elevation_deg = np.zeros(k)
        start = self._next
        first = min(k, self.max_samples - start)
        for column, values in (
            (self._tx, tx),
            (self._rx, rx),
            (self._distance_m, distance_m),
            (self._rssi_dbm, rssi),
            (self._elevation_deg, elevation_deg),
        ):
            column[start : start + first] = values[:first]
            column[: k - first] = values[first:]
        self._next = (start + k) % self.max_samples
        self._count = min(self._count + k, self.max_samples)


def _airborne(claim: ObservedClaim, min_height_m: float) -> ObservedClaim:
    """Only receptions with both ends at least ``min_height_m`` up (all when 0 or none)."""
    if min_height_m > 0.0 and claim.claimed_p_enu_m[2] < min_height_m:
        return receptions(claim, np.zeros(claim.n_receivers, dtype=bool))
    return airborne_receptions(claim, min_height_m)


def claim_links(claims: Sequence[ObservedClaim]) -> tuple[FloatArray, FloatArray]:
    """Every reception of ``claims`` (in order): its receiver's distance to the claimed
    position (m) and that link's elevation (``link_elevation_deg``)."""
    counts = [claim.n_receivers for claim in claims]
    claimed = np.repeat(claimed_positions(claims), counts, axis=0)
    offsets = np.concatenate([claim.rx_p_enu_m for claim in claims]) - claimed
    distance_m = _row_norms(offsets)
    return distance_m, link_elevation_deg(offsets[:, 2], distance_m)


def link_elevation_deg(dz_m: FloatArray, distance_m: FloatArray) -> FloatArray:
    """|asin(dz / d)| in degrees: how far off level a link runs (0 level, 90 vertical)."""
    ratio = np.abs(dz_m) / np.maximum(distance_m, 1.0)
    out: FloatArray = np.degrees(np.arcsin(np.minimum(ratio, 1.0)))
    return out


def _row_norms(offsets: FloatArray) -> FloatArray:
    """The length of each row (``np.linalg.norm(offsets, axis=1)``, the same arithmetic)."""
    norms: FloatArray = np.sqrt(np.add.reduce(offsets * offsets, axis=1))
    return norms


class _ReceiverPositions:
    """Each receiver's newest own reported position (ENU m) and its time (s), one row per
    receiver in the order first heard, found through a table indexed by system id. A
    cycle's claims update and are matched against them in one compiled call
    (``cooperative_kernels.update_and_match``)."""

    def __init__(self) -> None:
        self._row_of = np.full(256, -1, dtype=np.intp)  # by system id; -1: not heard yet
        self.sysid = np.zeros(0, dtype=np.int64)
        self.t_s = np.zeros(0)
        self.p_enu_m = np.zeros((0, 3))

    def update_and_match(
        self, claims: Sequence[ObservedClaim], match_age_s: float, match_m: float
    ) -> list[int | None]:
        """Each claim in order: its receivers take the newer of their positions, then the
        system id of the one receiver whose own position the claim is at (``match_m``, within
        ``match_age_s``), which did not hear it (nobody hears itself); None when none or
        several."""
        bounds = reception_bounds(claims)
        rows = self._rows(np.concatenate([c.rx_sysid for c in claims]))
        found = update_and_match(
            rows,
            np.concatenate([c.rx_t_s for c in claims]),
            np.concatenate([c.rx_p_enu_m for c in claims]),
            bounds,
            np.array([c.t_s for c in claims]),
            claimed_positions(claims),
            self.t_s,
            self.p_enu_m,
            float(match_age_s),
            float(match_m),
        )
        return [None if row < 0 else int(self.sysid[row]) for row in found.tolist()]

    def newest(self, sysid: int) -> tuple[float, FloatArray] | None:
        row = int(self._row_of[sysid]) if 0 <= sysid < self._row_of.shape[0] else -1
        if row < 0:
            return None
        return float(self.t_s[row]), self.p_enu_m[row]

    def _rows(self, sysid: NDArray[np.int64]) -> NDArray[np.intp]:
        if sysid.shape[0] and int(sysid.max()) >= self._row_of.shape[0]:
            grown = np.full(int(sysid.max()) + 1, -1, dtype=np.intp)
            grown[: self._row_of.shape[0]] = self._row_of
            self._row_of = grown
        rows: NDArray[np.intp] = self._row_of[sysid]
        if bool((rows < 0).any()):  # a receiver not heard before: add its row (rare)
            new = np.unique(sysid[rows < 0])
            self._row_of[new] = self.sysid.shape[0] + np.arange(new.shape[0])
            self.sysid = np.concatenate([self.sysid, new])
            self.t_s = np.concatenate([self.t_s, np.full(new.shape[0], -np.inf)])
            self.p_enu_m = np.concatenate([self.p_enu_m, np.zeros((new.shape[0], 3))])
            rows = self._row_of[sysid]
        return rows


class CooperativeLabeller:
    """Learns serial -> receiver system id from positions and collects labelled receptions."""

    _warm = False

    @classmethod
    def ensure_warm(cls) -> None:
        """Load (or compile) the kernel once per process, before a run's first cycle."""
        if not cls._warm:
            rx = np.array([[0.0, 0.0, 50.0], [400.0, 0.0, 80.0]])
            claim = ObservedClaim(
                "warm-up", 0.0, rx[0], None, np.array([2]), rx[1:], np.zeros(1), np.zeros(1)
            )
            _ReceiverPositions().update_and_match([claim], 1.0, 10.0)
            cls._warm = True

    def __init__(self, cfg: CalibrationConfig) -> None:
        self.cfg = cfg
        self._receivers = _ReceiverPositions()
        self._votes: dict[str, Counter[int]] = {}
        self._labels: dict[str, int] = {}  # what the votes say (``_vote``)
        self._claims: Counter[str] = Counter()  # claims seen per serial
        #: serial -> newest claim time (s), least recently heard first: what ``_forget`` drops
        self._last_heard_s: OrderedDict[str, float] = OrderedDict()
        self.samples = LabelledReceptions(cfg.max_samples)
        #: False once nothing will be fitted or checked again: labelled serials keep their
        #: label without further votes and yield no samples (serials not yet labelled
        #: still vote), so a claim costs little more than its receivers' update.
        self.learning = True

    def labels(self) -> dict[str, int]:
        """Serials labelled cooperative, with their receiver system id."""
        return dict(self._labels)

    def label_of(self, uas_id: str) -> int | None:
        """The receiver system id serial ``uas_id`` is labelled with, if it is cooperative."""
        return self._labels.get(uas_id)

    def strangers(self, min_claims: int) -> frozenset[str]:
        """Serials heard in at least ``min_claims`` claims, none of which matched a
        receiver's own position: no aircraft of the fleet accounts for them. A serial that
        ever matched is none (a fleet aircraft's claims match from its first ones; one that
        borrows a fleet serial, or once claims a receiver's own position, is left to the
        detectors)."""
        return frozenset(
            uas_id
            for uas_id, count in self._claims.items()
            if count >= min_claims and uas_id not in self._votes
        )

    def _vote(self, uas_id: str, sysid: int) -> None:
        votes = self._votes.get(uas_id)
        if votes is None:
            votes = self._votes[uas_id] = Counter()
        votes[sysid] += 1
        leader, count = votes.most_common(1)[0]
        total = sum(votes.values())
        if count >= self.cfg.min_matches and count >= (1 - self.cfg.max_mismatch_fraction) * total:
            self._labels[uas_id] = leader
        else:
            self._labels.pop(uas_id, None)

    def observe(self, claim: ObservedClaim) -> None:
        """Learn from one claim: receivers' own positions, a match vote, maybe samples."""
        self.observe_all([claim])

    def observe_all(self, claims: Sequence[ObservedClaim]) -> None:
        """``observe`` each claim in order (one compiled call for their receivers and
        matches)."""
        if not claims:
            return
        cfg = self.cfg
        matches = self._receivers.update_and_match(claims, cfg.match_age_s, cfg.match_m)
        labelled: list[tuple[int, ObservedClaim]] = []
        self._claims.update(claim.uas_id for claim in claims)
        self._forget(claims)
        for claim, match in zip(claims, matches, strict=True):
            if match is None or (not self.learning and self.label_of(claim.uas_id) is not None):
                continue
            self._vote(claim.uas_id, match)
            if self.label_of(claim.uas_id) == match:
                labelled.append((match, _airborne(claim, cfg.min_receiver_height_m)))
        self.samples.add_claims(labelled)

    def _forget(self, claims: Sequence[ObservedClaim]) -> None:
        """Note when each serial was heard; forget what is known of a serial silent for
        ``FORGET_AFTER_S`` (its count, votes, label), as the pipeline forgets its detectors:
        a stream of new serials must not grow the memory, nor ``strangers``' work. One heard
        again starts afresh (its samples stay)."""
        heard = self._last_heard_s
        for claim in claims:
            heard[claim.uas_id] = max(heard.pop(claim.uas_id, claim.t_s), claim.t_s)
        newest_s = max(heard[claim.uas_id] for claim in claims)
        while heard:
            uas_id, last_s = next(iter(heard.items()))
            if newest_s - last_s <= FORGET_AFTER_S:
                break
            del heard[uas_id], self._claims[uas_id]
            self._votes.pop(uas_id, None)
            self._labels.pop(uas_id, None)

    def vouches(self, claim: ObservedClaim) -> bool:
        """Is ``claim`` a labelled cooperative aircraft's, claiming where that aircraft last
        reported being (within ``vouch_m``)? Such a claim is no spoofer's."""
        sysid = self.label_of(claim.uas_id)
        if sysid is None or bool((claim.rx_sysid == sysid).any()):
            return False
        seen = self._receivers.newest(sysid)
        if seen is None:
            return False
        offset = seen[1] - claim.claimed_p_enu_m
        return float(offset @ offset) <= self.cfg.vouch_m**2
