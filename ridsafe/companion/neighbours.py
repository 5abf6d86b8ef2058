"""Other aircraft as their Remote ID claims them: the latest LOCATION per uas_id.

A claim is kept ``max_age_s`` after it was heard (a 1 Hz broadcaster missing two beats is
gone), excluding the aircraft's own serial. For the planner it becomes a
``planner_api.Neighbour`` in the local NED frame, flagged when the GCS has raised a
spoofing alert for that id. What a LOCATION claims (id, position, velocity) is read once
per decoded frame (``common.heard.LocationClaim``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Hashable
from dataclasses import dataclass

from ridsafe.common.frozen import quick_init
from ridsafe.common.heard import LocationClaim
from ridsafe.companion.planner_api import Neighbour, Vec3

__all__ = ["NeighbourTable"]

ToLocal = Callable[[float, float, float], Vec3]


@quick_init
@dataclass(frozen=True, slots=True)
class _Claim:
    claim: LocationClaim  # with a position
    t_s: float  # when heard, on the clock passed to ``update``


class NeighbourTable:
    """Latest claimed state per heard uas_id, excluding ``own_id``."""

    def __init__(self, own_id: str, max_age_s: float = 3.0) -> None:
        self.own_id = own_id
        self.max_age_s = max_age_s
        self._claims: dict[str, _Claim] = {}
        # Per uas_id: the claim, the frame and the flag its Neighbour was made for.
        self._made: dict[str, tuple[_Claim, Hashable, Neighbour]] = {}
        self.unusable = 0  # LOCATIONs without a position
        self._changes = 0  # claims kept or dropped so far: equal counts, equal claims
        self._oldest_s = math.inf  # no claim kept was heard before this
        # The last ``neighbours`` answer with a frame: (changes, frame, flagged, answer).
        self._answered: tuple[int, Hashable, frozenset[str], tuple[Neighbour, ...]] | None = None

    def __len__(self) -> int:
        return len(self._claims)

    def update(self, t_s: float, claim: LocationClaim) -> bool:
        """Record what a heard LOCATION claims (``DecodedRidFrame.claims``), received at
        ``t_s``; False if it is ours or unusable."""
        uas_id = claim.uas_id
        if uas_id == self.own_id:
            return False
        position = claim.position
        if position is None:
            self.unusable += 1
            return False
        kept = self._claims.get(uas_id)
        if kept is not None and kept.t_s > t_s:
            return False  # older than what is kept
        self._claims[uas_id] = _Claim(claim, t_s)
        self._changes += 1
        self._oldest_s = min(self._oldest_s, t_s)
        return True

    def expire(self, now_s: float) -> list[str]:
        """Drop the claims heard more than ``max_age_s`` before ``now_s``; their ids."""
        if now_s - self._oldest_s <= self.max_age_s:
            return []  # none is that old (a claim is replaced only by a later one)
        gone = [uas for uas, c in self._claims.items() if now_s - c.t_s > self.max_age_s]
        for uas in gone:
            del self._claims[uas]
            self._made.pop(uas, None)
        self._changes += len(gone)
        self._oldest_s = min((c.t_s for c in self._claims.values()), default=math.inf)
        return gone

    def neighbours(
        self,
        now_s: float,
        to_local: ToLocal,
        flagged: Collection[str] = (),
        frame: Hashable | None = None,
    ) -> tuple[Neighbour, ...]:
        """The current claims in the local NED frame, sorted by id.

        ``frame``: what ``to_local`` depends on (``OwnTelemetry.local_frame``); while it
        compares equal, a claim already converted is not converted again (a claim lives a
        second, and the planner asks twice a second), and while no claim came or went and the
        flagged ids are the same, the answer is the last one. None: every claim converted."""
        self.expire(now_s)
        answered = self._answered
        if (
            answered is not None
            and answered[0] == self._changes
            and frame is not None
            and answered[1] == frame
            and answered[2] == flagged
        ):
            return answered[3]
        out: list[Neighbour] = []
        made = self._made
        for uas, c in sorted(self._claims.items()):
            is_flagged = uas in flagged
            kept = made.get(uas)
            if (
                kept is not None
                and kept[0] is c
                and frame is not None
                and kept[1] == frame
                and kept[2].flagged is is_flagged
            ):
                out.append(kept[2])
                continue
            position = c.claim.position
            assert position is not None  # ``update`` keeps only claims with one
            neighbour = Neighbour(
                uas_id=uas,
                p_ned_m=to_local(*position),
                v_ned_m_s=c.claim.v_ned_m_s,
                t_s=c.t_s,
                flagged=is_flagged,
            )
            if frame is not None:
                made[uas] = (c, frame, neighbour)
            out.append(neighbour)
        answer = tuple(out)
        if frame is not None:
            self._answered = (self._changes, frame, frozenset(flagged), answer)
        return answer
