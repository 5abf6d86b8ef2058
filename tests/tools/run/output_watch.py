"""Read a child process's output as it comes, so a test can act once the child says it is
ready instead of after a fixed sleep (which a loaded machine outlasts)."""

from __future__ import annotations

import re
import subprocess
import threading
import time
from pathlib import Path


class OutputWatch:
    """Collects ``proc``'s stdout (text mode) on a thread."""

    def __init__(self, proc: subprocess.Popen[str]) -> None:
        assert proc.stdout is not None
        self.proc = proc
        self._chunks: list[str] = []
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        stream = self.proc.stdout
        assert stream is not None
        while chunk := stream.read(1):  # the progress bar redraws with "\r", not lines
            with self._lock:
                self._chunks.append(chunk)

    @property
    def text(self) -> str:
        with self._lock:
            return "".join(self._chunks)

    def wait_for(self, pattern: str, timeout_s: float) -> None:
        """Until ``pattern`` (a regex) appears; fails with the output so far if it does not,
        or if the process ends first."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if re.search(pattern, self.text):
                return
            if self.proc.poll() is not None:
                self._thread.join(timeout=5.0)
                break
            time.sleep(0.1)
        raise AssertionError(f"{pattern!r} not seen within {timeout_s:g} s:\n{self.text}")

    def finish(self, timeout_s: float) -> str:
        """Wait for the process to end; all of its output."""
        self.proc.wait(timeout=timeout_s)
        self._thread.join(timeout=5.0)
        return self.text


# tqdm's "sim time" bar once at least two simulated seconds have been flown
FLYING = r"\|\s*([2-9]|\d\d+)/\d+ "


def wait_for_text(path: Path, text: str, timeout_s: float) -> None:
    """Until the file at ``path`` (a child's log) contains ``text``."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if path.exists() and text in path.read_text(errors="replace"):
            return
        time.sleep(0.1)
    raise AssertionError(f"{text!r} not in {path} within {timeout_s:g} s")
