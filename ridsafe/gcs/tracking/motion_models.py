r"""Motion models of the IMM: constant velocity (CV, 6 states) and constant acceleration
(CA, 9 states), paper eq. (3)-(5), with the conversions that mix them.

State layout (ENU, metres and seconds), named here and nowhere else::

    CV: x = [p (3), v (3)]            CA: x = [p (3), v (3), a (3)]

optionally followed by ``n_extra`` states that no motion model touches (the RSSI filter's
transmit power, a random walk). Transitions over an interval dt (paper eq. (4), (5))::

    F_CV = [[I, dt I], [0, I]]
    F_CA = [[I, dt I, dt^2/2 I], [0, I, dt I], [0, 0, I]]

Process noise, two families:

- the paper's diagonal Q given per reference step dt_ref (appendix table), scaled by the real
  interval: Q(dt) = Q_paper * dt / dt_ref;
- continuous white noise on the highest derivative (Bar-Shalom, Li, Kirubarajan 2001,
  sec. 6.2.2-6.2.3), exact for any dt, with spectral density q_axis per axis (E, N, U)::

      CV: Q = [[dt^3/3, dt^2/2], [dt^2/2, dt]] (x) diag(q)
      CA: Q = [[dt^5/20, dt^4/8, dt^3/6],
               [dt^4/8,  dt^3/3, dt^2/2],
               [dt^3/6,  dt^2/2, dt    ]] (x) diag(q)

  In general Q[i, j] = q dt^(a+b+1) / (a! b! (a+b+1)), a = n-1-i, b = n-1-j (n = order).

Both families may add an altitude random walk ``z_diffusion`` (m^2/s) to Q[z, z].

Mixing across sizes (DESIGN.md section 6, the authors' choice): a CV estimate enters CA
*lifted*, with zero acceleration of variance sigma_a^2 (per axis) uncorrelated with the rest;
a CA estimate enters CV *truncated* (marginalised: drop the acceleration rows and columns).
All conversions work on batches: x (..., n), P (..., n, n).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

__all__ = [
    "ACC",
    "CA_DIM",
    "CV_DIM",
    "POS",
    "VEL",
    "MotionModel",
    "conversion_rows",
    "convert",
    "paper_process_noise",
    "transition_matrix",
    "white_noise_process_noise",
]

POS = slice(0, 3)
VEL = slice(3, 6)
ACC = slice(6, 9)
Z_INDEX = 2
CV_DIM = 6
CA_DIM = 9


def transition_matrix(order: int, dt_s: float) -> FloatArray:
    """F for order 2 (CV) or 3 (CA) over ``dt_s``: blocks dt^k / k! (x) I3."""
    blocks = np.zeros((order, order))
    for i in range(order):
        for j in range(i, order):
            blocks[i, j] = dt_s ** (j - i) / math.factorial(j - i)
    return np.asarray(np.kron(blocks, np.eye(3)), dtype=np.float64)


def paper_process_noise(q_diag: tuple[float, ...], dt_s: float, dt_ref_s: float) -> FloatArray:
    """The paper's diagonal Q (given per ``dt_ref_s``) scaled to the real interval."""
    return np.diag(np.asarray(q_diag, dtype=np.float64) * (dt_s / dt_ref_s))


def white_noise_process_noise(
    order: int, q_psd: float | tuple[float, float, float], dt_s: float
) -> FloatArray:
    """Exact discretisation of white noise on the highest derivative (module docstring);
    ``q_psd`` one spectral density for all axes or one per axis (E, N, U)."""
    blocks = np.zeros((order, order))
    for i in range(order):
        for j in range(order):
            a, b = order - 1 - i, order - 1 - j
            blocks[i, j] = dt_s ** (a + b + 1) / (
                math.factorial(a) * math.factorial(b) * (a + b + 1)
            )
    q_axes = np.broadcast_to(np.asarray(q_psd, dtype=np.float64), (3,))
    return np.asarray(np.kron(blocks, np.diag(q_axes)), dtype=np.float64)


@dataclass(frozen=True)
class MotionModel:
    """One kinematic hypothesis: ``order`` 2 (CV) or 3 (CA) and how its noise is made.

    Exactly one of ``q_diag`` (paper family, per ``dt_ref_s``) and ``q_psd`` (white-noise
    family; ``q_vertical_psd`` overrides the U axis) is set.
    """

    name: str
    order: int
    q_diag: tuple[float, ...] | None = None
    dt_ref_s: float = 0.25
    q_psd: float | None = None
    q_vertical_psd: float | None = None
    z_diffusion_m2_s: float = 0.0
    _cache: dict[float, tuple[FloatArray, FloatArray]] = field(
        default_factory=dict, compare=False, repr=False
    )

    def __post_init__(self) -> None:
        if self.order not in (2, 3):
            raise ValueError(f"order must be 2 (CV) or 3 (CA), got {self.order}")
        if (self.q_diag is None) == (self.q_psd is None):
            raise ValueError("set exactly one of q_diag and q_psd")
        if self.q_diag is not None and len(self.q_diag) != self.kin_dim:
            raise ValueError(f"q_diag needs {self.kin_dim} values, got {len(self.q_diag)}")

    @property
    def kin_dim(self) -> int:
        return 3 * self.order

    def transition(self, dt_s: float) -> FloatArray:
        return self.matrices(dt_s)[0]

    def noise(self, dt_s: float) -> FloatArray:
        return self.matrices(dt_s)[1]

    def matrices(self, dt_s: float) -> tuple[FloatArray, FloatArray]:
        """(F, Q) over ``dt_s``, cached (intervals repeat: cycle multiples). The interval is
        rounded to 1e-9 s before both, so the matrices do not depend on which of two
        intervals that round alike came first (a model lives across a sweep worker's runs)."""
        key = dt_s = round(dt_s, 9)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        if self.q_diag is not None:
            Q = paper_process_noise(self.q_diag, dt_s, self.dt_ref_s)
        else:
            assert self.q_psd is not None
            q_v = self.q_psd if self.q_vertical_psd is None else self.q_vertical_psd
            Q = white_noise_process_noise(self.order, (self.q_psd, self.q_psd, q_v), dt_s)
        Q[Z_INDEX, Z_INDEX] += self.z_diffusion_m2_s * dt_s
        out = (transition_matrix(self.order, dt_s), Q)
        if len(self._cache) > 4096:
            self._cache.clear()
        self._cache[key] = out
        return out


def convert(
    x: FloatArray,
    P: FloatArray,
    from_order: int,
    to_order: int,
    accel_var: float | FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """Move a (batch of) estimate(s) between kinematic orders, keeping trailing extra states.

    CV -> CA lifts (zero acceleration with variance ``accel_var``, one value or E, N, U,
    uncorrelated); CA -> CV truncates (marginalises the acceleration); equal orders copy.
    """
    if from_order == to_order:
        return x, P
    n_extra = x.shape[-1] - 3 * from_order
    keep, place, added = _index_maps(from_order, to_order, n_extra)
    if to_order < from_order:
        return x[..., keep], P[..., keep[:, None], keep]
    n_to = 3 * to_order + n_extra
    x_out = np.zeros((*x.shape[:-1], n_to))
    P_out = np.zeros((*P.shape[:-2], n_to, n_to))
    x_out[..., place] = x
    P_out[..., place[:, None], place] = P
    P_out[..., added, added] = np.broadcast_to(np.asarray(accel_var, dtype=np.float64), (3,))
    return x_out, P_out


@functools.cache
def conversion_rows(from_order: int, to_order: int, n_extra: int) -> NDArray[np.intp]:
    """``convert`` as an index map: row r of the converted state is row ``out[r]`` of the
    source, or a lifted acceleration (``out[r] = -1``; zero mean, ``accel_var``, uncorrelated).
    """
    keep, place, _ = _index_maps(from_order, to_order, n_extra)
    if to_order <= from_order:
        return keep
    out = np.full(3 * to_order + n_extra, -1, dtype=np.intp)
    out[place] = np.arange(place.shape[0])
    return out


@functools.cache
def _index_maps(
    from_order: int, to_order: int, n_extra: int
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.intp]]:
    """(kept source indices when truncating, where source states land when lifting, the
    lifted acceleration's indices)."""
    k_from, k_to = 3 * from_order, 3 * to_order
    keep = np.r_[0:k_to, k_from : k_from + n_extra]
    place = np.r_[0:k_from, k_to : k_to + n_extra]
    added = np.arange(k_from, k_to)
    return keep, place, added
