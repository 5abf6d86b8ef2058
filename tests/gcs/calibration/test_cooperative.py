"""The labeller's compiled update-and-match against the rule written out in numpy, claim by
claim: a cycle's claims give the same matches whether they come one at a time or together."""

from __future__ import annotations

import numpy as np
import pytest

from ridsafe.gcs.calibration.config import CalibrationConfig
from ridsafe.gcs.calibration.cooperative import CooperativeLabeller, LabelledReceptions
from ridsafe.gcs.pipeline_api import ObservedClaim, readonly

CFG = CalibrationConfig(enabled=True, match_m=10.0, match_age_s=1.0)


def _reference_matches(claims: list[ObservedClaim]) -> list[int | None]:
    """Each claim in order: its receivers keep their newest position, then the one receiver
    (not among those that heard it) within match_m of the claim at most match_age_s off."""
    newest: dict[int, tuple[float, np.ndarray]] = {}
    out: list[int | None] = []
    for c in claims:
        for sysid, t, p in zip(c.rx_sysid.tolist(), c.rx_t_s.tolist(), c.rx_p_enu_m, strict=True):
            if sysid not in newest or t >= newest[sysid][0]:
                newest[sysid] = (t, p)
        heard = set(c.rx_sysid.tolist())
        found = [
            sysid
            for sysid, (t, p) in newest.items()
            if sysid not in heard
            and abs(t - c.t_s) <= CFG.match_age_s
            and float(np.sum((p - c.claimed_p_enu_m) ** 2)) <= CFG.match_m**2
        ]
        out.append(found[0] if len(found) == 1 else None)
    return out


def _random_cycle(rng: np.random.Generator, n: int, t0: float) -> list[ObservedClaim]:
    """Claims by n aircraft, some at a receiver's position (a cooperative one), some near
    two at once, some far from all, each heard by a random subset of the others."""
    positions = rng.uniform(-300.0, 300.0, (n, 3))
    positions[: n // 4] = positions[0] + rng.normal(0.0, 3.0, (n // 4, 3))  # a crowded pad
    claims = []
    for k in range(n):
        others = np.flatnonzero((np.arange(n) != k) & (rng.random(n) < 0.7))
        rx_t = t0 + rng.uniform(0.0, 0.25, others.shape[0])
        claimed = (
            positions[k] + rng.normal(0.0, 4.0, 3)
            if rng.random() < 0.8
            else rng.uniform(-300.0, 300.0, 3)
        )
        rx_sysid = (others + 1).astype(np.int64)
        rx_sysid.setflags(write=False)
        claims.append(
            ObservedClaim(
                f"RID{k}",
                t0,
                readonly(claimed),
                None,
                rx_sysid,
                readonly(positions[others] + rng.normal(0.0, 1.0, (others.shape[0], 3))),
                readonly(rx_t),
                readonly(np.full(others.shape[0], -70.0)),
            )
        )
    return claims


def test_a_cycle_matches_as_its_claims_one_by_one() -> None:
    rng = np.random.default_rng(5)
    together, one_by_one = CooperativeLabeller(CFG), CooperativeLabeller(CFG)
    all_claims: list[ObservedClaim] = []
    matched = 0
    for cycle in range(40):
        claims = _random_cycle(rng, 24, 0.25 * cycle)
        all_claims += claims
        got = together._receivers.update_and_match(claims, CFG.match_age_s, CFG.match_m)
        assert got == _reference_matches(all_claims)[-len(claims) :]
        matched += sum(m is not None for m in got)
        for claim in claims:
            one_by_one.observe(claim)
    assert 0 < matched < 40 * 24  # both outcomes happened
    unique_labels = CooperativeLabeller(CFG)
    unique_labels.observe_all(all_claims)
    assert unique_labels.labels() == one_by_one.labels()


@pytest.mark.parametrize("max_samples", [50, 700, 5000])
def test_a_cycle_adds_the_rows_one_add_per_claim_would(max_samples: int) -> None:
    """The batched write against a ring written one reception at a time, the distances
    written out: the same columns row by row, wrapping around the ring (50: a cycle larger
    than the ring, which goes claim by claim)."""
    rng = np.random.default_rng(2)
    batched = LabelledReceptions(max_samples)
    rows: list[list[float]] = [[0.0] * 4 for _ in range(max_samples)]
    added = 0
    for cycle in range(12):
        claims = _random_cycle(rng, 24, 0.25 * cycle)
        labelled = [(int(k) + 1, claim) for k, claim in enumerate(claims) if k % 3]
        batched.add_claims(labelled)
        for tx, claim in labelled:
            distance = np.linalg.norm(claim.rx_p_enu_m - claim.claimed_p_enu_m, axis=1)
            for rx, d, rssi in zip(claim.rx_sysid, distance, claim.rssi_dbm, strict=True):
                rows[added % max_samples] = [tx, rx, d, rssi]
                added += 1
        written = np.array(rows[: min(added, max_samples)])
        for j, column in enumerate(("tx_sysid", "rx_sysid", "distance_m", "rssi_dbm")):
            assert np.array_equal(getattr(batched, column), written[:, j])
        assert len(batched) == min(added, max_samples)
    assert (added > max_samples) == (max_samples < 5000)  # wrapped, or never full
