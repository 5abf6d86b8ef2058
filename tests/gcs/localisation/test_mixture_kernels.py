"""The Gaussian sum's compiled merge distance is a twin of the containment reference
(``ridsafe.common.ellipsoid.mahalanobis2``): equal on positive definite sums, inf where the
sum is not positive definite (such a pair never merges)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ridsafe.common.ellipsoid import mahalanobis2
from ridsafe.gcs.localisation.mixture_kernels import pair_mahalanobis2


def _spd(rng: np.random.Generator, scale: float) -> np.ndarray:
    a = rng.normal(size=(3, 3))
    return scale * (a @ a.T + 0.05 * np.eye(3))


@settings(max_examples=50)
@given(st.integers(0, 2**32 - 1), st.floats(1e-2, 1e4), st.integers(2, 6))
def test_pair_distances_equal_the_reference(seed: int, scale: float, n: int) -> None:
    rng = np.random.default_rng(seed)
    p = rng.normal(0.0, 50.0, (n, 3))
    C = np.stack([_spd(rng, scale) for _ in range(n)])
    m2 = pair_mahalanobis2(p, C)
    for a in range(n):
        for b in range(n):
            if b <= a:
                assert m2[a, b] == np.inf
                continue
            reference = float(mahalanobis2(p[a] - p[b], C[a] + C[b]))
            assert m2[a, b] == pytest.approx(reference, rel=1e-9, abs=1e-12)


def test_an_axis_aligned_pair_by_hand() -> None:
    p = np.array([[0.0, 0.0, 0.0], [30.0, 0.0, 4.0]])
    C = np.stack((np.diag([400.0, 100.0, 4.0]), np.diag([500.0, 100.0, 12.0])))
    # 30^2 / 900 + 4^2 / 16 = 1 + 1
    assert pair_mahalanobis2(p, C)[0, 1] == pytest.approx(2.0, rel=1e-12)
    assert float(mahalanobis2(p[1] - p[0], C[0] + C[1])) == pytest.approx(2.0, rel=1e-12)


def test_not_positive_definite_sums_never_merge() -> None:
    p = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    indefinite = np.diag([1.0, -2.0, 1.0])
    C = np.stack((indefinite, np.zeros((3, 3))))
    assert pair_mahalanobis2(p, C)[0, 1] == np.inf
    # the reference ignores the direction of negative variance (here: 1); the twin refuses
    assert np.isfinite(mahalanobis2(p[1] - p[0], C[0] + C[1]))
