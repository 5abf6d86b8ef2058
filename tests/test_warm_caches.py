"""``tests/warm_caches.py`` fills only the caches it knows and says which it does not."""

from __future__ import annotations

import pytest

from tests import warm_caches


def test_an_unknown_cache_is_refused_by_name_before_anything_is_warmed() -> None:
    with pytest.raises(SystemExit, match=r"unknown cache\(s\) \['numbaa'\]; numba or mypy"):
        warm_caches.main(["numbaa", "mypy"])
