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
from collections import Counter, deque
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ridsafe.gcs.calibration.config import CalibrationConfig
from ridsafe.gcs.pipeline_api import ObservedClaim

FloatArray = NDArray[np.float64]

__all__ = ["CooperativeLabeller", "LabelledReceptions"]


@dataclass
class LabelledReceptions:
    """Growing columns of labelled receptions (bounded at ``max_samples``)."""

    max_samples: int
    tx_sysid: deque[int] = field(default_factory=deque)
    rx_sysid: deque[int] = field(default_factory=deque)
    distance_m: deque[float] = field(default_factory=deque)
    rssi_dbm: deque[float] = field(default_factory=deque)

    def __len__(self) -> int:
        return len(self.rssi_dbm)

    def n_parameters(self) -> int:
        """Parameters a channel fit of these receptions has (``channel_fit.py``): the
        exponent, a bias per receiver and a level per transmitter."""
        return 1 + len(set(self.rx_sysid)) + len(set(self.tx_sysid))

    def add(self, tx: int, rx: NDArray[np.int64], distance_m: FloatArray, rssi: FloatArray) -> None:
        for column, values in (
            (self.tx_sysid, [tx] * rx.shape[0]),
            (self.rx_sysid, rx.tolist()),
            (self.distance_m, distance_m.tolist()),
            (self.rssi_dbm, rssi.tolist()),
        ):
            column.extend(values)
            while len(column) > self.max_samples:
                column.popleft()


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


class CooperativeLabeller:
    """Learns serial -> receiver system id from positions and collects labelled receptions."""

    def __init__(self, cfg: CalibrationConfig) -> None:
        self.cfg = cfg
        self._rx_seen: dict[int, tuple[float, FloatArray]] = {}  # sysid -> (t_s, p_enu_m)
        self._votes: dict[str, Counter[int]] = {}
        self.samples = LabelledReceptions(cfg.max_samples)

    def labels(self) -> dict[str, int]:
        """Serials labelled cooperative, with their receiver system id."""
        out = {uas_id: self.label_of(uas_id) for uas_id in self._votes}
        return {uas_id: sysid for uas_id, sysid in out.items() if sysid is not None}

    def label_of(self, uas_id: str) -> int | None:
        """The receiver system id serial ``uas_id`` is labelled with, if it is cooperative."""
        votes = self._votes.get(uas_id)
        if not votes:
            return None
        sysid, count = votes.most_common(1)[0]
        total = sum(votes.values())
        if count >= self.cfg.min_matches and count >= (1 - self.cfg.max_mismatch_fraction) * total:
            return sysid
        return None

    def observe(self, claim: ObservedClaim) -> None:
        """Learn from one claim: receivers' own positions, a match vote, maybe samples."""
        for sysid, t, p in zip(claim.rx_sysid, claim.rx_t_s, claim.rx_p_enu_m, strict=True):
            seen = self._rx_seen.get(int(sysid))
            if seen is None or t >= seen[0]:
                self._rx_seen[int(sysid)] = (float(t), p)
        match = self._match(claim)
        if match is None:
            return
        self._votes.setdefault(claim.uas_id, Counter())[match] += 1
        if self.label_of(claim.uas_id) == match:
            claim = _airborne(claim, self.cfg.min_receiver_height_m)
            distance = np.linalg.norm(claim.rx_p_enu_m - claim.claimed_p_enu_m, axis=1)
            self.samples.add(match, claim.rx_sysid, distance, claim.rssi_dbm)

    def vouches(self, claim: ObservedClaim) -> bool:
        """Is ``claim`` a labelled cooperative aircraft's, claiming where that aircraft last
        reported being (within ``vouch_m``)? Such a claim is no spoofer's."""
        sysid = self.label_of(claim.uas_id)
        if sysid is None or sysid in claim.rx_sysid.tolist():
            return False
        seen = self._rx_seen.get(sysid)
        if seen is None:
            return False
        return float(np.linalg.norm(seen[1] - claim.claimed_p_enu_m)) <= self.cfg.vouch_m

    def _match(self, claim: ObservedClaim) -> int | None:
        hearers = set(claim.rx_sysid.tolist())
        found: list[int] = []
        for sysid, (t, p) in self._rx_seen.items():
            if sysid in hearers or abs(t - claim.t_s) > self.cfg.match_age_s:
                continue
            if float(np.linalg.norm(p - claim.claimed_p_enu_m)) <= self.cfg.match_m:
                found.append(sysid)
        return found[0] if len(found) == 1 else None
