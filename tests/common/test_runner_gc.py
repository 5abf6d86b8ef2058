"""An app's startup objects are frozen out of the garbage collector's reach before its run
starts, so no full collection walks them inside a ``handle`` call (issue 14: a 174 ms call
in the companion's 1M fuzz campaign, 173 ms of it such a collection)."""

from __future__ import annotations

import gc
import time

from ridsafe.common.runner import freeze_startup_objects


def test_what_exists_at_startup_is_frozen_and_full_collections_no_longer_walk_it() -> None:
    startup = [[k] for k in range(200_000)]  # a heap of long-lived objects, as kernels are
    try:
        freeze_startup_objects()
        assert gc.get_freeze_count() >= len(startup)
        start = time.thread_time()
        gc.collect()
        frozen_ms = (time.thread_time() - start) * 1e3
        gc.unfreeze()
        start = time.thread_time()
        gc.collect()
        walked_ms = (time.thread_time() - start) * 1e3
        assert frozen_ms < walked_ms
    finally:
        gc.unfreeze()
