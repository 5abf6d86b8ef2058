"""The compiled scene (``scene_kernel``) against the array expressions it replaced, bit for
bit: a decision must not depend on which of the two computed its scene."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray

from ridsafe.companion.planner_config import PlannerConfig
from ridsafe.companion.planner_eval import _eigen
from ridsafe.companion.scene_kernel import project_neighbours, project_regions

FloatArray = NDArray[np.float64]
CFG = PlannerConfig()
TAU = np.asarray(CFG.sample_times_s, dtype=np.float64)
TAU_ALL = np.concatenate([[0.0], TAU, CFG.extension_times_s])


def _bits(x: FloatArray) -> NDArray[np.uint64]:
    return np.ascontiguousarray(x).view(np.uint64)


def _neighbours_by_arrays(
    q: FloatArray, w: FloatArray, age: FloatArray, p0: FloatArray
) -> tuple[FloatArray, NDArray[np.bool_]]:
    horizon = age[:, None] + TAU[None, :]
    pos: FloatArray = q[:, None, :] + w[:, None, :] * horizon[..., None]
    dist = np.linalg.norm(pos - p0, axis=-1)
    keep = np.any(dist < CFG.d_safe_m + CFG.max_speed_m_s * TAU, axis=1)
    return pos, keep


def _regions_by_arrays(
    c: FloatArray,
    v: FloatArray,
    lam: FloatArray,
    vec: FloatArray,
    age: FloatArray,
    p0: FloatArray,
    sqrt_chi2: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    horizon = np.maximum(age[:, None] + TAU_ALL[None, :], 0.0)
    center = c[:, None, :] + v[:, None, :] * horizon[..., None]
    lam_k = lam[:, None, :] + ((CFG.region_velocity_std_m_s * horizon) ** 2)[..., None]
    pinv = np.einsum("rij,rkj,rlj->rkil", vec, 1.0 / lam_k, vec)
    sigma = np.sqrt(lam_k.min(axis=-1))
    delta = p0 - center
    m = np.einsum("rki,rkij,rkj->rk", delta, pinv, delta)
    d = sigma * np.maximum(0.0, np.sqrt(np.maximum(m, 0.0)) - sqrt_chi2[:, None])
    return center, pinv, sigma, d


@pytest.mark.parametrize("seed", range(40))
def test_neighbours_projected_bit_for_bit(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 20))
    q = rng.uniform(-400.0, 400.0, (n, 3)) * [1, 1, 0.1]
    w = rng.uniform(-9.0, 9.0, (n, 3)) * [1, 1, 0.2]
    age = rng.uniform(0.0, 2.0, n)
    p0 = rng.uniform(-100.0, 100.0, 3)
    now_s = 50.0
    rows = np.concatenate([q, w, (now_s - age)[:, None]], axis=1)
    want_pos, want_keep = _neighbours_by_arrays(q, w, now_s - rows[:, 6], p0)
    pos, keep = project_neighbours(rows, now_s, TAU, p0, CFG.d_safe_m, CFG.max_speed_m_s)
    assert np.array_equal(_bits(pos), _bits(want_pos))
    assert np.array_equal(keep, want_keep)


def test_neighbours_kept_and_dropped_both_occur() -> None:
    rows = np.array([[50.0, 0.0, -60.0, 0, 0, 0, 0.0], [5000.0, 0.0, -60.0, 0, 0, 0, 0.0]])
    p0 = np.array([0.0, 0.0, -60.0])
    _, keep = project_neighbours(rows, 0.0, TAU, p0, CFG.d_safe_m, CFG.max_speed_m_s)
    assert keep.tolist() == [True, False]


@pytest.mark.parametrize("seed", range(40))
def test_regions_projected_bit_for_bit(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 4))
    c = rng.uniform(-300.0, 300.0, (n, 3)) * [1, 1, 0.2]
    v = rng.uniform(-9.0, 9.0, (n, 3)) * [1, 1, 0.1]
    covs = []
    for _ in range(n):
        a = rng.normal(0.0, 20.0, (3, 3))
        covs.append(a @ a.T + np.diag(rng.uniform(0.0, 50.0, 3)))
    eigen = [_eigen(cov.tobytes()) for cov in covs]
    lam, vec = np.array([e[0] for e in eigen]), np.array([e[1] for e in eigen])
    age = rng.uniform(-1.0, 3.0, n)  # a region stamped after now is held at its estimate
    p0 = rng.uniform(-100.0, 100.0, 3)
    sqrt_chi2 = np.sqrt(rng.uniform(5.0, 12.0, n))
    want = _regions_by_arrays(c, v, lam, vec, age, p0, sqrt_chi2)
    got = project_regions(c, v, lam, vec, age, TAU_ALL, CFG.region_velocity_std_m_s, p0, sqrt_chi2)
    for name, g, w in zip(("centre", "P^-1", "sigma_min", "distance"), got, want, strict=True):
        assert np.array_equal(_bits(g), _bits(w)), name
