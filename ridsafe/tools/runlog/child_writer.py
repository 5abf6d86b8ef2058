"""The MCAP recorder on the machine's other core: a ``LogSink`` that hands records to a
:class:`~ridsafe.tools.runlog.writer.McapRecorder` in a child process.

A lockstep run is one thread of Python; encoding its records as JSON, deriving the Foxglove
scenes and compressing chunks took about an eighth of its wall time. Here the run's process
only pickles each record (a snapshot taken when it is logged, as the recorder's own JSON
encoding is) and sends them in batches through a pipe; the child writes exactly what an
in-process recorder would, in the same order.

Batches go out every ``batch_records`` records and whenever sim time passes the recorder's
next flush point, so what a crash of the run's process can lose stays what the recorder
itself promises (one flush interval). The child ignores Ctrl-C (the terminal sends it to the
whole process group): it finishes the file when the run closes the sink, or when the pipe
reaches end of file because the run's process died. An error in the child (a record JSON
cannot hold, a full disk) ends the child with a finished file up to that record; the run
learns of it as a :class:`~ridsafe.tools.runlog.writer.RecorderError` at its next batch or at
``close()``.
"""

from __future__ import annotations

import contextlib
import io
import logging
import multiprocessing
import multiprocessing.connection
import os
import pickle
import signal
import threading
from collections.abc import Iterator, Sequence
from multiprocessing.context import ForkContext, SpawnContext
from pathlib import Path

from ridsafe.common.logsink import Record
from ridsafe.tools.runlog.writer import (
    DEFAULT_FLUSH_EVERY_S,
    McapRecorder,
    RecorderError,
    WriterPlugin,
)

__all__ = ["RecorderProcess", "ctrl_c_deferred", "pickle_record"]

logger = logging.getLogger(__name__)

DEFAULT_BATCH_RECORDS = 512
_JOIN_TIMEOUT_S = 60.0


class RecorderProcess:
    """A ``LogSink`` writing ``path`` through a recorder in a child process (see the module
    docstring); ``plugins`` are the recorder's (they run in the child: picklable, and fresh)."""

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        plugins: Sequence[WriterPlugin] = (),
        batch_records: int = DEFAULT_BATCH_RECORDS,
    ) -> None:
        if batch_records < 1:
            raise ValueError(f"batch_records must be >= 1, got {batch_records}")
        self.path = Path(path)
        self._batch_records = batch_records
        self._pending: list[bytes] = []
        self._flush_every_s = DEFAULT_FLUSH_EVERY_S
        self._next_send_s = self._flush_every_s
        self._closed = False
        # fork where there is one: the child starts at once with every module loaded.
        context: ForkContext | SpawnContext = multiprocessing.get_context("spawn")
        if "fork" in multiprocessing.get_all_start_methods():
            context = multiprocessing.get_context("fork")
        records_out, records_in = context.Pipe(duplex=False)
        result_out, result_in = context.Pipe(duplex=False)
        self._records = records_in
        self._result = result_out
        self._process = context.Process(
            target=_record,
            args=(
                records_out,
                result_in,
                (records_in, result_out),
                str(self.path),
                tuple(plugins),
                self._flush_every_s,
            ),
            name="ridsafe-recorder",
            daemon=False,
        )
        with ctrl_c_deferred():  # until the child ignores it, Ctrl-C is noted, not raised
            self._process.start()
        records_out.close()
        result_in.close()

    def log(self, topic: str, t_s: float, record: Record) -> None:
        if self._closed:
            raise RecorderError(f"{topic}: log() after close() of {self.path}")
        self._pending.append(pickle_record(topic, t_s, record))
        if t_s >= self._next_send_s:  # where the child's recorder flushes (its own rule)
            self._next_send_s = t_s + self._flush_every_s
            self._send()
        elif len(self._pending) >= self._batch_records:
            self._send()

    def close(self) -> None:
        """Send what is left, let the child finish the file and wait for it; raises
        RecorderError if the child failed. Safe to call twice."""
        if self._closed:
            return
        self._closed = True
        try:
            self._send()
            self._records.send_bytes(b"")  # end of records
        except (RecorderError, OSError):
            pass  # the child is gone; its own report, read below, says why
        finally:
            self._records.close()
        error = self._child_result()
        self._process.join(_JOIN_TIMEOUT_S)
        if self._process.is_alive():
            self._process.kill()
            raise RecorderError(f"recorder process for {self.path} did not finish; killed")
        if error:
            raise RecorderError(error)

    def __enter__(self) -> RecorderProcess:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _send(self) -> None:
        if not self._pending:
            return
        batch, self._pending = b"".join(self._pending), []
        try:
            with ctrl_c_deferred():  # a batch cut in half would garble the pipe
                self._records.send_bytes(batch)
        except OSError as exc:  # BrokenPipeError: the child is gone
            raise RecorderError(
                f"recorder process for {self.path} stopped: {self._child_result() or exc}"
            ) from exc

    def _child_result(self) -> str:
        """The child's error text ('' when it finished cleanly or said nothing)."""
        try:
            if self._result.poll(_JOIN_TIMEOUT_S):
                return str(self._result.recv())
        except (EOFError, OSError):
            pass
        code = self._process.exitcode
        return "" if code in (0, None) else f"recorder process exited with code {code}"


def pickle_record(topic: str, t_s: float, record: Record) -> bytes:
    """What crosses to another process for ``log(topic, t_s, record)``: a snapshot of the
    record now; RecorderError if it cannot be pickled."""
    try:
        return pickle.dumps((topic, t_s, record), pickle.HIGHEST_PROTOCOL)
    except (pickle.PicklingError, TypeError, AttributeError) as exc:
        raise RecorderError(f"{topic}: record cannot be handed to the recorder: {exc}") from exc


@contextlib.contextmanager
def ctrl_c_deferred() -> Iterator[None]:
    """Hold Ctrl-C (SIGINT) until the block is done, then act on it as the handler before
    would have (``KeyboardInterrupt`` by default). A handler of its own notes it meanwhile;
    blocking the signal would not do: one that arrived just before the block still raises
    inside it. Outside the main thread (which alone handles signals) nothing to hold."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, _frame: caught.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if caught:
            if callable(previous):
                previous(signal.SIGINT, None)
            elif previous == signal.SIG_DFL:
                signal.raise_signal(signal.SIGINT)


def _record(
    records: multiprocessing.connection.Connection,
    result: multiprocessing.connection.Connection,
    parent_ends: tuple[multiprocessing.connection.Connection, ...],
    path: str,
    plugins: tuple[WriterPlugin, ...],
    flush_every_s: float,
) -> None:
    """The child: write every record received until the empty batch or end of file."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    for end in parent_ends:  # a forked child holds copies: end of file must mean the run died
        end.close()
    error = ""
    try:
        recorder = McapRecorder(
            path, plugins=plugins, flush_every_s=flush_every_s
        )  # flushes where the run sends its batches
        with recorder:
            while True:
                try:
                    batch = records.recv_bytes()
                except EOFError:
                    logger.warning("recorder: the run's process went away; finishing %s", path)
                    break
                if not batch:
                    break
                stream = io.BytesIO(batch)
                while stream.tell() < len(batch):
                    topic, t_s, record = pickle.load(stream)
                    recorder.log(topic, t_s, record)
    except Exception as exc:  # reported to the run, which raises it
        error = f"{type(exc).__name__}: {exc}"
    finally:
        result.send(error)
        result.close()
        records.close()
