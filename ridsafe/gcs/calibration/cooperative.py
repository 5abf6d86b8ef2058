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

import dataclasses
from collections import Counter

import numpy as np
from numpy.typing import NDArray

from ridsafe.gcs.calibration.config import CalibrationConfig
from ridsafe.gcs.pipeline_api import ObservedClaim

FloatArray = NDArray[np.float64]

__all__ = ["CooperativeLabeller", "LabelledReceptions"]


class LabelledReceptions:
    """The newest ``max_samples`` labelled receptions, as columns (a ring buffer: the
    oldest overwritten; order is not kept, the fit and the check need none)."""

    def __init__(self, max_samples: int) -> None:
        self.max_samples = max_samples
        self._tx = np.zeros(max_samples, dtype=np.int64)
        self._rx = np.zeros(max_samples, dtype=np.int64)
        self._distance_m = np.zeros(max_samples)
        self._rssi_dbm = np.zeros(max_samples)
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

    def n_parameters(self) -> int:
        """Parameters a channel fit of these receptions has (``channel_fit.py``): the
        exponent, a bias per receiver and a level per transmitter."""
        n_rx, n_tx = np.unique(self.rx_sysid).shape[0], np.unique(self.tx_sysid).shape[0]
        return 1 + int(n_rx) + int(n_tx)

    def add(self, tx: int, rx: NDArray[np.int64], distance_m: FloatArray, rssi: FloatArray) -> None:
        k = min(rx.shape[0], self.max_samples)
        rows = (self._next + np.arange(k)) % self.max_samples
        self._tx[rows] = tx
        self._rx[rows] = rx[-k:]
        self._distance_m[rows] = distance_m[-k:]
        self._rssi_dbm[rows] = rssi[-k:]
        self._next = (self._next + k) % self.max_samples
        self._count = min(self._count + k, self.max_samples)


def _airborne(claim: ObservedClaim, min_height_m: float) -> ObservedClaim:
    """Only receptions with both ends at least ``min_height_m`` up (all when 0 or none)."""
    if min_height_m <= 0.0:
        return claim
    if claim.claimed_p_enu_m[2] < min_height_m:
        keep = np.zeros(claim.n_receivers, dtype=bool)
    else:
        keep = claim.rx_p_enu_m[:, 2] >= min_height_m
    return dataclasses.replace(
        claim,
        rx_sysid=claim.rx_sysid[keep],
        rx_p_enu_m=claim.rx_p_enu_m[keep],
        rx_t_s=claim.rx_t_s[keep],
        rssi_dbm=claim.rssi_dbm[keep],
    )


class _ReceiverPositions:
    """Each receiver's newest own reported position (ENU m) and its time (s), as arrays
    sorted by system id, so one claim's receivers update and one claim's match are a few
    vector operations whatever the fleet's size."""

    def __init__(self) -> None:
        self.sysid = np.zeros(0, dtype=np.int64)
        self.t_s = np.zeros(0)
        self.p_enu_m = np.zeros((0, 3))

    def update(
        self, sysid: NDArray[np.int64], t_s: FloatArray, p_enu_m: FloatArray
    ) -> NDArray[np.intp]:
        """Take the newer of each receiver's positions; return the receivers' rows."""
        rows = self._rows(sysid)
        newer = t_s >= self.t_s[rows]
        self.t_s[rows[newer]] = t_s[newer]
        self.p_enu_m[rows[newer]] = p_enu_m[newer]
        return rows

    def newest(self, sysid: int) -> tuple[float, FloatArray] | None:
        row = int(np.searchsorted(self.sysid, sysid))
        if row == self.sysid.shape[0] or self.sysid[row] != sysid:
            return None
        return float(self.t_s[row]), self.p_enu_m[row]

    def _rows(self, sysid: NDArray[np.int64]) -> NDArray[np.intp]:
        rows = np.searchsorted(self.sysid, sysid)
        known = rows < self.sysid.shape[0]
        known[known] = self.sysid[rows[known]] == sysid[known]
        if not bool(known.all()):  # a receiver not seen before: insert it (rare)
            new = np.unique(sysid[~known])
            order = np.argsort(np.concatenate([self.sysid, new]), kind="stable")
            self.sysid = np.concatenate([self.sysid, new])[order]
            self.t_s = np.concatenate([self.t_s, np.full(new.shape[0], -np.inf)])[order]
            self.p_enu_m = np.concatenate([self.p_enu_m, np.zeros((new.shape[0], 3))])[order]
            rows = np.searchsorted(self.sysid, sysid)
        return rows


class CooperativeLabeller:
    """Learns serial -> receiver system id from positions and collects labelled receptions."""

    def __init__(self, cfg: CalibrationConfig) -> None:
        self.cfg = cfg
        self._receivers = _ReceiverPositions()
        self._votes: dict[str, Counter[int]] = {}
        self._labels: dict[str, int] = {}  # what the votes say (``_vote``)
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
        heard_by = self._receivers.update(claim.rx_sysid, claim.rx_t_s, claim.rx_p_enu_m)
        if not self.learning and self.label_of(claim.uas_id) is not None:
            return
        match = self._match(claim, heard_by)
        if match is None:
            return
        self._vote(claim.uas_id, match)
        if self.label_of(claim.uas_id) == match:
            claim = _airborne(claim, self.cfg.min_receiver_height_m)
            distance = np.linalg.norm(claim.rx_p_enu_m - claim.claimed_p_enu_m, axis=1)
            self.samples.add(match, claim.rx_sysid, distance, claim.rssi_dbm)

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

    def _match(self, claim: ObservedClaim, heard_by: NDArray[np.intp]) -> int | None:
        """The one receiver whose own position the claim is at; ``heard_by``: the rows of
        the receivers that heard it (nobody hears itself)."""
        r = self._receivers
        candidate = np.abs(r.t_s - claim.t_s) <= self.cfg.match_age_s
        candidate[heard_by] = False
        candidate &= np.sum((r.p_enu_m - claim.claimed_p_enu_m) ** 2, axis=1) <= self.cfg.match_m**2
        found = r.sysid[candidate]
        return int(found[0]) if found.shape[0] == 1 else None
