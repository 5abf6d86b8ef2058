"""Ctrl-C in tests, whatever the shell that started pytest did with SIGINT.

A shell starts a background job (``pytest ... &``, a CI step) with SIGINT ignored, and a
child inherits that: a test that sends SIGINT would then see it ignored, and Python would
not turn it into KeyboardInterrupt. Tests about Ctrl-C set the disposition a terminal gives.
"""

from __future__ import annotations

import contextlib
import signal
from collections.abc import Iterator


@contextlib.contextmanager
def keyboard_interrupt_on_sigint() -> Iterator[None]:
    """In this process: SIGINT raises KeyboardInterrupt for the block (then as before). A
    child started inside the block starts with SIGINT's default action (exec resets a
    handled signal, but keeps an ignored one ignored), as from a terminal."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
