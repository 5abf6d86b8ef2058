"""Where sweep runs fly: :func:`execute` (one run, in a worker) and the engines.

Both engines satisfy :class:`ridsafe.tools.sweep.runner.Engine` (``run(base, specs,
out_dir)`` yields a :class:`~ridsafe.tools.sweep.folder.RunOutcome` per spec as runs finish)
and call :func:`execute`, so their metrics are identical (lockstep runs are deterministic;
only wall-clock and compute-time keys differ):

- :class:`LocalPoolEngine`: ``concurrent.futures.ProcessPoolExecutor``, one spawned process
  per core; each imports ridsafe once (numba kernels from its cache), receives the base
  scenario once, and flies many runs, writing each log straight into the sweep folder.
- :class:`DaskEngine`: Dask distributed, an existing scheduler (``--scheduler ADDRESS``) or a
  ``LocalCluster`` (one single-threaded worker process per core, on 127.0.0.1). The base is
  scattered once; workers log to a temporary folder and return the log's bytes with the
  metrics, so a cluster needs no shared file system (workers need ridsafe installed).

Workers pin numba/OpenMP/BLAS to one thread (:data:`THREAD_ENV`, set before they start) so N
workers on N cores do not oversubscribe. Start external Dask workers with ``--nthreads 1``
and these variables set (a running worker has loaded numpy's BLAS already).
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import os
import socket
import tempfile
import threading
import time
import traceback
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from multiprocessing import get_context
from pathlib import Path
from typing import Any

from ridsafe.tools.run import process
from ridsafe.tools.run.scenario import ScenarioFile
from ridsafe.tools.sweep.folder import LOG_FILE, Metrics, RunOutcome, RunStatus, run_metrics
from ridsafe.tools.sweep.plan import RunSpec, scenario_for

__all__ = [
    "THREAD_ENV",
    "DaskEngine",
    "LocalPoolEngine",
    "default_workers",
    "execute",
    "failed",
    "metrics_of_logs",
]

#: Set in every worker process: one thread each for numba's parallel layer, OpenMP and BLAS.
THREAD_ENV: Mapping[str, str] = {
    "NUMBA_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
}
_MAX_LOG_LINES = 2000


# --------------------------------------------------------------------------------------------
# One run


class _Capture(logging.Handler):
    """The run's warnings, for run.log (a worker's stderr would tear the progress bar)."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.setFormatter(logging.Formatter("%(levelname)s %(name)s: %(message)s"))
        self.lines: list[str] = []
        self.dropped = 0

    def emit(self, record: logging.LogRecord) -> None:
        if len(self.lines) < _MAX_LOG_LINES:
            self.lines.append(self.format(record))
        else:
            self.dropped += 1

    def result(self) -> tuple[str, ...]:
        extra = [f"... {self.dropped} more lines dropped"] if self.dropped else []
        return (*self.lines, *extra)


def execute(base: ScenarioFile, spec: RunSpec, run_dir: Path | None) -> RunOutcome:
    """Fly ``spec`` and compute its metrics; never raises for the run's own failures.

    ``run_dir``: where run.mcap goes; None: a temporary folder, and the log's bytes come back
    in the outcome (Dask workers on other machines)."""
    for name, value in THREAD_ENV.items():
        os.environ[name] = value  # for libraries this process has not loaded yet
    capture = _Capture()
    root = logging.getLogger()
    root.addHandler(capture)
    try:
        if run_dir is not None:
            return dataclasses.replace(_fly(base, spec, run_dir), log_lines=capture.result())
        with tempfile.TemporaryDirectory(prefix="ridsafe-run-") as tmp:
            outcome = _fly(base, spec, Path(tmp))
            log_path = Path(tmp) / LOG_FILE
            log = log_path.read_bytes() if log_path.exists() else None
            return dataclasses.replace(outcome, log_lines=capture.result(), log=log)
    finally:
        root.removeHandler(capture)


def _fly(base: ScenarioFile, spec: RunSpec, run_dir: Path) -> RunOutcome:
    from ridsafe.tools.run.lockstep import run_lockstep  # noqa: PLC0415

    worker = f"{socket.gethostname()}:{os.getpid()}"
    started = time.perf_counter()
    try:
        # Recorder in this process: the engine already runs a worker on every core.
        log_path = run_dir / LOG_FILE
        result = run_lockstep(
            scenario_for(base, spec), spec.planner, log_path, recorder_process=False
        )
        metrics = run_metrics(result.log_path)
    except Exception:  # a failed run is a result, not the end of the sweep
        wall = time.perf_counter() - started
        return RunOutcome(spec, RunStatus.FAILED, traceback.format_exc(), {}, wall, None, worker)
    status = RunStatus(result.status)
    return RunOutcome(
        spec, status, result.reason, metrics, result.wall_clock_s, result.sim_time_s, worker
    )


def failed(spec: RunSpec, reason: str) -> RunOutcome:
    """The outcome of a spec whose worker gave no answer."""
    return RunOutcome(spec, RunStatus.FAILED, reason, {}, 0.0, None, "")


# --------------------------------------------------------------------------------------------
# Engines


def default_workers() -> int:
    """Every core this process may use."""
    return process.usable_cpus()


@contextlib.contextmanager
def _thread_env() -> Iterator[None]:
    """:data:`THREAD_ENV` in this process's environment while workers are spawned."""
    saved = {name: os.environ.get(name) for name in THREAD_ENV}
    os.environ.update(THREAD_ENV)
    try:
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def metrics_of_logs(
    logs: Sequence[Path],
    workers: int = 1,
    on_done: Callable[[int, int], None] | None = None,
) -> list[Metrics]:
    """:func:`~ridsafe.tools.sweep.folder.run_metrics` of each log, in the order given, on
    ``workers`` spawned processes (in this one for one worker or one log); ``on_done(done,
    total)`` after each. An error in any log is raised here."""
    results: list[Metrics | None] = [None] * len(logs)
    if workers <= 1 or len(logs) <= 1:
        for k, log in enumerate(logs):
            results[k] = run_metrics(log)
            if on_done is not None:
                on_done(k + 1, len(logs))
    else:
        with _thread_env():
            pool = ProcessPoolExecutor(
                max_workers=workers,
                mp_context=get_context("spawn"),
                initializer=_exit_with_parent,
                initargs=(os.getpid(),),
            )
        with pool:
            futures = {pool.submit(run_metrics, log): k for k, log in enumerate(logs)}
            for done, future in enumerate(as_completed(futures), start=1):
                results[futures[future]] = future.result()
                if on_done is not None:
                    on_done(done, len(logs))
    metrics = [r for r in results if r is not None]
    if len(metrics) != len(logs):  # every future either returned or raised above
        raise RuntimeError(f"metrics of {len(logs) - len(metrics)} of {len(logs)} logs missing")
    return metrics


_WORKER_BASE: ScenarioFile | None = None
#: How often a pool worker checks that the process that started it is still there (s).
PARENT_POLL_S = 1.0


def _exit_with_parent(parent_pid: int) -> None:
    """In a pool worker: exit once the process that started it is gone (a sweep killed,
    even with SIGKILL, leaves no worker behind; without this they waited forever on a
    queue nobody writes). A run cut short has no result, so the next sweep flies it."""

    def watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(PARENT_POLL_S)
        os._exit(1)

    threading.Thread(target=watch, name="parent-watch", daemon=True).start()


def _init_pool_worker(base: ScenarioFile, parent_pid: int) -> None:
    global _WORKER_BASE  # noqa: PLW0603 (one base per worker process, sent once)
    _WORKER_BASE = base
    _exit_with_parent(parent_pid)


def _pool_task(spec: RunSpec, run_dir: str) -> RunOutcome:
    if _WORKER_BASE is None:
        raise RuntimeError("sweep worker started without its base scenario")
    return execute(_WORKER_BASE, spec, Path(run_dir))


@dataclass
class LocalPoolEngine:
    """A ``ProcessPoolExecutor`` of ``workers`` spawned processes. A worker that dies (out of
    memory, a crash in compiled code) breaks the pool: the runs in it are retried once in a
    fresh pool, then recorded as failed."""

    workers: int = field(default_factory=default_workers)
    name: str = "pool"

    def run(
        self, base: ScenarioFile, specs: Sequence[RunSpec], out_dir: Path
    ) -> Iterator[RunOutcome]:
        pending, retried = list(specs), set[RunSpec]()
        while pending:
            broken: list[RunSpec] = []
            for spec, outcome in self._one_pool(base, pending, out_dir):
                if outcome is not None:
                    yield outcome
                elif spec in retried:
                    yield failed(spec, "its worker process died twice (memory? a crash?)")
                else:
                    broken.append(spec)
            retried.update(broken)
            pending = broken

    def _one_pool(
        self, base: ScenarioFile, specs: Sequence[RunSpec], out_dir: Path
    ) -> Iterator[tuple[RunSpec, RunOutcome | None]]:
        """(spec, outcome), or (spec, None) when the pool broke under it."""
        with _thread_env():
            pool = ProcessPoolExecutor(
                max_workers=self.workers,
                mp_context=get_context("spawn"),
                initializer=_init_pool_worker,
                initargs=(base, os.getpid()),
            )
        try:
            futures: dict[Future[RunOutcome], RunSpec] = {
                pool.submit(_pool_task, spec, str(out_dir / spec.run_dir)): spec for spec in specs
            }
            for future in as_completed(futures):
                try:
                    yield futures[future], future.result()
                except BrokenProcessPool:
                    yield futures[future], None
        finally:
            pool.shutdown(wait=True, cancel_futures=True)


@dataclass
class DaskEngine:
    """Dask distributed: the scheduler at ``scheduler`` (``tcp://host:8786``), or a
    ``LocalCluster`` of ``workers`` single-threaded worker processes on 127.0.0.1."""

    workers: int = field(default_factory=default_workers)
    scheduler: str | None = None
    name: str = "dask"

    def run(
        self, base: ScenarioFile, specs: Sequence[RunSpec], out_dir: Path
    ) -> Iterator[RunOutcome]:
        from distributed import as_completed as dask_as_completed  # noqa: PLC0415

        if not specs:
            return
        with self._client() as client:
            shared = client.scatter(base, broadcast=True)
            futures = {
                client.submit(execute, shared, spec, None, pure=False): spec for spec in specs
            }
            try:
                for future in dask_as_completed(futures):  # type: ignore[no-untyped-call]
                    yield _dask_outcome(future, futures[future])
            finally:
                client.cancel(list(futures))

    @contextlib.contextmanager
    def _client(self) -> Iterator[Any]:
        from distributed import Client, LocalCluster  # noqa: PLC0415

        if self.scheduler is not None:
            with Client(self.scheduler) as client:  # type: ignore[no-untyped-call]
                yield client
            return
        cluster = LocalCluster(  # type: ignore[no-untyped-call]
            n_workers=self.workers,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
            env=dict(THREAD_ENV),
        )
        with cluster, Client(cluster) as client:  # type: ignore[no-untyped-call]
            yield client


def _dask_outcome(future: Any, spec: RunSpec) -> RunOutcome:
    try:
        outcome = future.result()
    except Exception as err:  # e.g. KilledWorker: the worker died running it, repeatedly
        return failed(spec, f"{type(err).__name__}: {err}")
    if not isinstance(outcome, RunOutcome):
        return failed(spec, f"worker returned {type(outcome).__name__}, not a RunOutcome")
    return outcome
