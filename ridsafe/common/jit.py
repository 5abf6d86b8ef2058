"""The numba decorators every compiled kernel of ridsafe uses (the sim's dynamics, the
planner's scoring and scene, the GCS's ``*_kernels.py``).

``jit``: compiled in nopython mode and cached on disk beside the kernel's module (the first
run after an edit compiles again). numba's cache does not track other modules: after
editing a kernel that calls into another module, delete that package's
``__pycache__/*.nb[ci]``. ``jit_inline``: ``jit`` for a kernel's small helpers, inlined into
their caller at numba's IR level (a call per sample otherwise costs as much as the
arithmetic it does). ``jit_fastmath`` also lets the compiler reassociate sums: only for
kernels whose results need no bit-exact order (the track-start grid). All keep the
function's type for mypy.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar, cast

from numba import njit

__all__ = ["jit", "jit_fastmath", "jit_inline"]

_F = TypeVar("_F", bound=Callable[..., Any])


def jit(fn: _F) -> _F:
    """``numba.njit(cache=True)``, typed."""
    return cast(_F, njit(cache=True)(fn))


def jit_inline(fn: _F) -> _F:
    """``numba.njit(cache=True, inline="always")``, typed."""
    return cast(_F, njit(cache=True, inline="always")(fn))


def jit_fastmath(fn: _F) -> _F:
    """``numba.njit(cache=True, fastmath=True)``, typed."""
    return cast(_F, njit(cache=True, fastmath=True)(fn))
