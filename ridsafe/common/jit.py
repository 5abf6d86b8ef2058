"""The numba decorators every compiled kernel of ridsafe uses (the sim's dynamics, the
planner's scoring and scene, the GCS's ``*_kernels.py``).

``jit``: compiled in nopython mode and cached on disk beside the kernel's module (the first
run after an edit compiles again). numba's cache does not track other modules: after
editing a kernel that calls into another module, delete that package's
``__pycache__/*.nb[ci]``. ``jit_inline``: ``jit`` for a kernel's small helpers, inlined into
their caller at numba's IR level (a call per sample otherwise costs as much as the
arithmetic it does). Both keep the function's type for mypy.

No kernel is compiled with ``fastmath``: it lets the compiler reorder sums, so the same
call may round differently in another compilation, and which compiled code a run gets
depends on what numba's on-disk cache held before it. The track-start grid had it: the same
scenario and seed started its first track a few ulps apart after a paper run had filled the
cache than from an empty one, and every later value of that track differed with it
(without it, the two give the same log). ``tests/common/test_jit.py`` holds the rule.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar, cast

from numba import njit

__all__ = ["jit", "jit_inline"]

_F = TypeVar("_F", bound=Callable[..., Any])


def jit(fn: _F) -> _F:
    """``numba.njit(cache=True)``, typed."""
    return cast(_F, njit(cache=True)(fn))


def jit_inline(fn: _F) -> _F:
    """``numba.njit(cache=True, inline="always")``, typed."""
    return cast(_F, njit(cache=True, inline="always")(fn))
