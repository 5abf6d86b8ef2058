"""A lockstep run on two processes: the serial run's log, record for record, on two cores.

The serial run (:class:`~ridsafe.tools.run.lockstep.Lockstep`) calls, every tick, the sim, the
companions in system-id order and the GCS. Two facts let half of that run elsewhere: within
a tick the companions never hear one another, and the GCS of tick t and the sim of tick t+1
need nothing from each other (the GCS's replies reach the companions at t+1; the sim hears
the companions of tick t). So a forked worker runs the GCS and every other companion, this
process the sim and the rest:

    this process:  sim(t)    | companions[0::2](t) | sim(t+1)  | ...
    worker:        GCS(t-1)  | companions[1::2](t) | GCS(t)    | ...

Every other companion, not the first half and the second: the scenarios launch aircraft in
system-id order, so halves would differ in how many fly (and plan) at a time, and each
exchange waits for the slower process.

At each ``|`` the two exchange the datagrams that cross between them. The worker sends its
half as soon as it has it (the GCS's answer before the sim's tick comes, its companions'
datagrams for the sim before this process's companions are done), so this process finds it
waiting instead of asking and waiting for the worker's pickling and the pipe; an answer too
big to be sure of fitting the socket's buffer waits until the worker has read this process's
next message, as every message did before, so neither can block the other on a full pipe.
Every core is given the same input, in the same order, at the same sim time as in the serial
run, so it does the same thing.

Most of the GCS's steps send and log nothing (no cycle, heartbeat or counters due: the
GCS's ``quiet_at``), yet some are its heaviest (a second's reports of the whole fleet
arriving at once). For those the worker answers "nothing" at once and runs the step later,
a datagram at a time while it waits for this process, and every such step before any other
step of the GCS (``_QuietSteps``): the GCS gets the calls ``handle`` would make, in the
same order, so it does the same thing. This process waits for them only where some are
still pending at the GCS's next step that is not quiet.

The worker also writes the log, in the time it waits for this process and has no quiet step
left to run (one record at a time, looking for the next message between two). A core's
records go to its process's :class:`LaneBuffer` (pickled when logged: a snapshot, as the
recorder's own pickling is), each tagged with the core that logged it; this process sends
its own with the datagrams, and the worker writes them all in the serial order (GCS(t-1),
sim(t), companions by system id). A third process (the recorder child of a serial run)
would take the core from one of the two at random moments and hold up both.
"""

from __future__ import annotations

import collections
import contextlib
import multiprocessing
import multiprocessing.connection
import pickle
import signal
import time
import traceback
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from multiprocessing.reduction import ForkingPickler
from typing import Any, Protocol, cast, runtime_checkable

from ridsafe.common.logsink import LogSink, Record
from ridsafe.common.router import ByteRouter, Port
from ridsafe.common.shell import Datagrams, SansIoCore
from ridsafe.tools.run.process import usable_cpus
from ridsafe.tools.runlog.child_writer import ctrl_c_deferred, pickle_record

__all__ = [
    "Core",
    "LaneBuffer",
    "PhaseTimes",
    "Roles",
    "SplitLockstep",
    "WorkerError",
    "can_split",
    "in_serial_order",
    "log_pickled",
]

#: How long this process waits for the worker's answer before calling it dead (s). A tick is
#: milliseconds; the first tick of the GCS (its kernels warm) under a second.
_ANSWER_TIMEOUT_S = 120.0
_CLOSE_TIMEOUT_S = 600.0  # closing: the worker first writes what is pending (seconds' worth)
_JOIN_TIMEOUT_S = 10.0
#: Each process looks for the other's message this long before it sleeps on the pipe (the
#: worker once it has no record left to write): the message often comes sooner than a
#: sleeping process is woken, and they wait for each other twice a tick. On the 2-core
#: development machine (a virtual one) 100 us gave 16 + 1 in 6.13 s, 1 ms 5.70 s, 5 ms no
#: better; the cost is CPU time spun (9.6 -> 10.3 s) on the two CPUs the run has to itself.
_SPIN_S = 1e-3
#: Answers the worker sends before it is asked, at most this big (a socket pair holds ~176 kB:
#: two of them and the other side's can never fill it).
_EARLY_MAX_BYTES = 32_768
#: Records the worker lets wait for a quiet moment; beyond, it writes them before it answers.
_MAX_PENDING_RECORDS = 200_000

Pickled = bytes  # pickle of (topic, t_s, record)
Lane = str  # the core that logged a record ('' outside every core's step)
Laned = tuple[Lane, Pickled]


@dataclass
class PhaseTimes:
    """Where a process of a split run spent its ticks (s of wall clock, ``time.perf_counter``):
    by phase, filled in as it steps. This process: ``sim``, ``companions`` (its half),
    ``sending``, ``waiting_gcs`` (after the sim, for the GCS's answer) and ``waiting_companions``
    (after its half, for the worker's); the worker: ``gcs``, ``companions``, ``writing`` (the
    log, in the time it waits), ``idle``. Each tick has two barriers (the sim beside the GCS,
    then the halves of the companions): what one side waits is the other side's longer phase.
    The rest (pickling the records, ordering them) is in no phase."""

    seconds: dict[str, float] = field(default_factory=dict)
    by_tick: dict[str, dict[int, float]] = field(default_factory=dict)  # and by ``tick``:
    tick: int = 0  # the tick's place in its second (this process's stepper sets it)

    def add(self, phase: str, started_s: float) -> float:
        """Count the time since ``started_s`` to ``phase``; returns now."""
        now_s = time.perf_counter()
        self.seconds[phase] = self.seconds.get(phase, 0.0) + now_s - started_s
        ticks = self.by_tick.setdefault(phase, {})
        ticks[self.tick] = ticks.get(self.tick, 0.0) + now_s - started_s
        return now_s


@dataclass
class LaneBuffer:
    """The ``LogSink`` of every core of one process of a split run: records, pickled, in the
    order they were logged, each with the core that logged it (:meth:`lane`), until
    :meth:`take`."""

    records: list[Laned] = field(default_factory=list)
    _lane: Lane = field(default="", init=False, repr=False)

    def log(self, topic: str, t_s: float, record: Record) -> None:
        self.records.append((self._lane, pickle_record(topic, t_s, record)))

    def take(self) -> list[Laned]:
        out, self.records = self.records, []
        return out

    @contextlib.contextmanager
    def lane(self, core: Lane) -> Iterator[None]:
        """What is logged in the block is ``core``'s."""
        self._lane = core
        try:
            yield
        finally:
            self._lane = ""


def log_pickled(blob: Pickled, sink: LogSink) -> None:
    """Log one record of a :class:`LaneBuffer` to ``sink`` as its core logged it."""
    sink.log(*pickle.loads(blob))


def in_serial_order(records: Iterable[Laned], order: Sequence[Lane]) -> list[Laned]:
    """``records`` of cores that stepped side by side, as the serial run logs them: core by
    core in ``order`` (the router's), each core's in the order it logged them; records of
    no core first."""
    rank = {core: index for index, core in enumerate(order)}
    return sorted(records, key=lambda laned: rank.get(laned[0], -1))


def can_split() -> bool:
    """Whether a run may use a second process here: fork exists and two CPUs are ours (its
    affinity and its cgroup's quota; on one CPU the two processes would take turns)."""
    return "fork" in multiprocessing.get_all_start_methods() and usable_cpus() >= 2


class Core(SansIoCore, Protocol):
    """A lockstep core: ``handle`` every tick, ``finish`` once at the end of the run."""

    def finish(self, now_s: float) -> object: ...  # what it returns is not sent


@runtime_checkable
class StepsInParts(Protocol):
    """A core whose step may run in parts (``handle`` = ``begin``, ``receive``..., ``tick``)
    and that says which steps can send and log nothing (``quiet_at``): the GCS."""

    def begin(self, now_s: float) -> None: ...

    def receive(self, now_s: float, inbound: Datagrams) -> None: ...

    def tick(self, now_s: float) -> Datagrams: ...

    def quiet_at(self, now_s: float) -> bool: ...


class WorkerError(RuntimeError):
    """The worker process of a split run failed or went away."""


@dataclass(frozen=True)
class Roles:
    """Which of a lockstep router's cores is the sim, which the GCS, which the companions (in
    the router's order: the sim first, the GCS last)."""

    sim: str
    gcs: str
    companions: tuple[str, ...]


@dataclass(frozen=True)
class _Routes:
    """Where each core's datagrams go: the router's wires."""

    router: ByteRouter

    def split(self, core: str, sent: Datagrams, into: dict[str, Datagrams]) -> None:
        """Append what ``core`` sent to the inbox lists in ``into``, by destination core."""
        for endpoint, data in sent:
            dest: Port | None = self.router.destination(core, endpoint)
            if dest is not None:
                into[dest[0]].append((dest[1], data))


class SplitLockstep:
    """The cores of a lockstep run, all logging to ``buffer``, stepped on this process and a
    forked worker that writes the log (``open_log()``, called in the worker; see the module
    docstring). Same interface as :class:`~ridsafe.tools.run.lockstep.Lockstep` where a run
    needs it: ``step``, ``t_s``, ``finish``. Then what this process logs after ``finish``
    goes to ``buffer`` too, and :meth:`close` has it written and the log closed; on ``with``
    exit the worker ends in any case."""

    def __init__(
        self,
        router: ByteRouter,
        roles: Roles,
        tick_s: float,
        buffer: LaneBuffer,
        open_log: Callable[[], LogSink],
    ) -> None:
        if router.order != [roles.sim, *roles.companions, roles.gcs]:
            raise ValueError(f"a split run needs the order sim, companions, GCS: {router.order}")
        self.tick_s = tick_s
        self.ticks = 0
        self._roles = roles
        self._buffer = buffer
        names = list(roles.companions)
        self._names, self._there_names = names, names[1::2]
        cores = cast(dict[str, Core], router.cores)
        self._here = [(name, cores[name]) for name in names[0::2]]
        there = [(name, cores[name]) for name in self._there_names]
        self._sim = cores[roles.sim]
        self._routes = _Routes(router)
        self._sim_inbox: Datagrams = []
        #: Where this process's ticks went; the worker's, once :meth:`close` has run.
        self.times, self.worker_times = PhaseTimes(), PhaseTimes()
        self._finished = self._closed = False
        context = multiprocessing.get_context("fork")
        self._conn, worker_end = context.Pipe(duplex=True)
        self._process = context.Process(
            target=_work,
            args=(worker_end, self._conn, router, roles, there, buffer, open_log),
            name="ridsafe-lockstep-worker",
            daemon=True,
        )
        with ctrl_c_deferred():  # until the worker ignores it, Ctrl-C is noted, not raised
            self._process.start()
        worker_end.close()
        buffer.take()  # what was logged before the fork: the worker writes its own copy
        try:
            self._answer(_ANSWER_TIMEOUT_S)  # the worker has opened the log
        except WorkerError:
            self._end_worker()
            raise

    @property
    def t_s(self) -> float:
        return self.ticks * self.tick_s

    @property
    def worker_pid(self) -> int | None:
        return self._process.pid

    def step(self) -> float:
        """One tick of every core (the GCS's part of it finishes on the worker during the
        next tick); returns its sim time."""
        self.ticks += 1
        now_s = self.ticks * self.tick_s
        with ctrl_c_deferred():  # a tick cut in half would leave the worker mid-exchange
            self._step(now_s)
        return now_s

    def _step(self, now_s: float) -> None:
        times, started = self.times, time.perf_counter()
        times.tick = round(now_s / self.tick_s) % max(1, round(1.0 / self.tick_s))
        sim_inbox, self._sim_inbox = self._sim_inbox, []
        to_companions: dict[str, Datagrams] = {name: [] for name in self._names}
        with self._buffer.lane(self._roles.sim):
            sent_by_sim = self._sim.handle(now_s, sim_inbox)
        self._routes.split(self._roles.sim, sent_by_sim, to_companions)
        there = {name: to_companions[name] for name in self._there_names}
        started = times.add("sim", started)
        self._conn.send(("step", now_s, there, self._buffer.take()))
        started = times.add("sending", started)
        from_gcs: dict[str, Datagrams] = self._answer(_ANSWER_TIMEOUT_S)
        started = times.add("waiting_gcs", started)
        inboxes = {name: from_gcs[name] + to_companions[name] for name, _ in self._here}
        to_sim, to_gcs = _step_companions(
            self._routes, self._roles, self._here, inboxes, now_s, self._buffer
        )
        started = times.add("companions", started)
        self._conn.send((to_gcs, self._buffer.take()))
        started = times.add("sending", started)
        to_sim.update(self._answer(_ANSWER_TIMEOUT_S))
        times.add("waiting_companions", started)
        self._sim_inbox = _in_companion_order(to_sim, self._names)

    def finish(self) -> None:
        """The serial run's ``finish``: after the last tick's GCS, the companions, the GCS and
        the sim say goodbye, in that order."""
        if self._finished:
            return
        self._finished = True
        now_s = self.t_s
        with ctrl_c_deferred():
            for name, core in self._here:
                with self._buffer.lane(name):
                    core.finish(now_s)
            self._conn.send(("finish", now_s, {}, self._buffer.take()))
            self._answer(_ANSWER_TIMEOUT_S)  # the last GCS's answer: no tick follows
            self._answer(_ANSWER_TIMEOUT_S)  # the worker's companions and the GCS are done
            self._sim.finish(now_s)

    def close(self) -> None:
        """Have the worker write what this process logged since and close the log; raises
        WorkerError if it could not. Safe to call twice."""
        if self._closed:
            return
        self._closed = True
        try:
            with ctrl_c_deferred():
                self._conn.send(("close", self.t_s, {}, self._buffer.take()))
                self._answer(_CLOSE_TIMEOUT_S)  # the answer sent before it was asked
                self.worker_times = PhaseTimes(self._answer(_CLOSE_TIMEOUT_S))
        finally:
            self._end_worker()

    def __enter__(self) -> SplitLockstep:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self._end_worker()

    def _end_worker(self) -> None:
        """End the worker (it closes the log on end of file); safe to call twice."""
        with contextlib.suppress(OSError):
            self._conn.close()
        self._process.join(_CLOSE_TIMEOUT_S if self._closed else _JOIN_TIMEOUT_S)
        if self._process.is_alive():
            self._process.kill()
            self._process.join(_JOIN_TIMEOUT_S)

    def _answer(self, timeout_s: float) -> Any:
        """The worker's next answer; raises WorkerError if it failed or is gone."""
        try:
            if not _spin(self._conn) and not self._conn.poll(timeout_s):
                raise WorkerError(f"lockstep worker silent for {timeout_s:g} s")
            message = self._conn.recv()
        except (EOFError, OSError) as exc:
            self._process.join(_JOIN_TIMEOUT_S)
            code = self._process.exitcode
            raise WorkerError(f"lockstep worker went away (exit code {code})") from exc
        if message[0] == "error":
            raise WorkerError(f"lockstep worker failed:\n{message[1]}")
        return message[1]


def _spin(conn: multiprocessing.connection.Connection) -> bool:
    """Whether something arrives on ``conn`` within ``_SPIN_S`` (looking, not sleeping)."""
    end = time.perf_counter() + _SPIN_S
    while not conn.poll():
        if time.perf_counter() > end:
            return False
    return True


class _QuietSteps:
    """The GCS's quiet steps (``StepsInParts.quiet_at``: nothing to send or log), answered
    for at once (nothing) and run later, a datagram at a time, while the worker waits; all
    of them before any other step of the GCS. The GCS gets the same calls in the same order
    as from ``handle``, so it does the same thing."""

    def __init__(self, core: StepsInParts, buffer: LaneBuffer) -> None:
        self.core = core
        self.buffer = buffer
        self.pending: collections.deque[tuple[float, Datagrams]] = collections.deque()
        self._next = -1  # of the oldest pending step: -1 to begin, then its next datagram

    def defer(self, now_s: float, inbox: Datagrams) -> bool:
        """Keep the step at ``now_s`` for later if it is quiet; False if it must run now."""
        if not self.core.quiet_at(now_s):
            return False
        self.pending.append((now_s, inbox))
        return True

    def run_one(self) -> bool:
        """One part of the oldest pending step; False if none is pending."""
        if not self.pending:
            return False
        now_s, inbox = self.pending[0]
        logged = len(self.buffer.records)
        if self._next < 0:
            self.core.begin(now_s)
            self._next = 0
        elif self._next < len(inbox):
            self.core.receive(now_s, inbox[self._next : self._next + 1])
            self._next += 1
        else:
            sent = self.core.tick(now_s)
            if sent:
                raise RuntimeError(f"a quiet step of the GCS at t={now_s:.3f} s sent {sent!r}")
            self.pending.popleft()
            self._next = -1
        if len(self.buffer.records) != logged:
            raise RuntimeError(f"a quiet step of the GCS at t={now_s:.3f} s logged records")
        return True

    def run_all(self) -> None:
        while self.run_one():
            pass


class _Writer:
    """The worker's log: records wait in order and are written while the worker waits, after
    the GCS's quiet steps (``quiet``). ``times``: where the worker's ticks went (its writing,
    idle time and those steps counted here)."""

    def __init__(
        self, log: LogSink, first: Sequence[Laned], quiet: _QuietSteps | None = None
    ) -> None:
        self.log = log
        self.pending: collections.deque[Laned] = collections.deque(first)
        self.quiet = quiet
        self.closed = False
        self.times = PhaseTimes()

    def add(self, records: Sequence[Laned]) -> None:
        self.pending.extend(records)
        while len(self.pending) > _MAX_PENDING_RECORDS:
            self.write_one()

    def write_one(self) -> None:
        log_pickled(self.pending.popleft()[1], self.log)

    def wait_for(self, conn: multiprocessing.connection.Connection) -> Any:
        """The next message on ``conn``, writing pending records until it is there."""
        started = time.perf_counter()
        while not conn.poll():
            if self.quiet is not None and self.quiet.run_one():
                started = self.times.add("gcs", started)
            elif self.pending:
                self.write_one()
                started = self.times.add("writing", started)
            else:
                if not _spin(conn):
                    conn.poll(None)
                started = self.times.add("idle", started)
        return conn.recv()

    def close(self) -> None:
        """Write what is pending and close the log; once."""
        if self.closed:
            return
        self.closed = True
        try:
            while self.pending:
                self.write_one()
        finally:
            close = getattr(self.log, "close", None)
            if close is not None:
                close()


def _work(
    conn: multiprocessing.connection.Connection,
    parent_end: multiprocessing.connection.Connection,
    router: ByteRouter,
    roles: Roles,
    cores: list[tuple[str, Core]],
    buffer: LaneBuffer,
    open_log: Callable[[], LogSink],
) -> None:
    """The worker: the GCS one tick behind, the companions ``cores`` and the log (see the
    module docstring), until told to close or the run's process goes away."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the run's process decides on Ctrl-C
    parent_end.close()  # end of file must mean the run's process is gone
    writer: _Writer | None = None
    try:
        gcs = router.cores[roles.gcs]
        quiet = _QuietSteps(gcs, buffer) if isinstance(gcs, StepsInParts) else None
        writer = _Writer(open_log(), buffer.take(), quiet)
        conn.send(("ok", None))  # the log is open
        _serve(conn, _Routes(router), roles, cores, buffer, writer)
        writer.close()
        conn.send(("ok", writer.times.seconds))
    except (EOFError, BrokenPipeError):
        pass  # the run's process is gone: the log is finished below with what came
    except BaseException:  # reported to the run's process, which raises it
        with contextlib.suppress(OSError):
            conn.send(("error", traceback.format_exc()))
    finally:
        if writer is not None:
            writer.close()


def _serve(
    conn: multiprocessing.connection.Connection,
    routes: _Routes,
    roles: Roles,
    cores: list[tuple[str, Core]],
    buffer: LaneBuffer,
    writer: _Writer,
) -> None:
    """Answer the run's process until it says close; the log's last records are written by
    the caller (``_Writer.close``). Where the worker's ticks went: ``writer.times``."""
    gcs = cast(Core, routes.router.cores[roles.gcs])
    quiet = writer.quiet
    mine = {name for name, _ in cores}
    order = routes.router.order
    gcs_inbox: Datagrams = []
    gcs_now_s: float | None = None
    while True:
        to_companions: dict[str, Datagrams] = {name: [] for name in roles.companions}
        if gcs_now_s is not None:
            started = time.perf_counter()
            if quiet is None or not quiet.defer(gcs_now_s, gcs_inbox):
                if quiet is not None:
                    quiet.run_all()
                with buffer.lane(roles.gcs):
                    sent_by_gcs = gcs.handle(gcs_now_s, gcs_inbox)
                routes.split(roles.gcs, sent_by_gcs, to_companions)
            writer.times.add("gcs", started)
            gcs_now_s = None
        writer.add(buffer.take())  # the GCS's records come before the sim's of the next tick
        theirs = {name: sent for name, sent in to_companions.items() if name not in mine}
        kind, now_s, from_sim, records = _answer_and_wait(conn, writer, ("ok", theirs))
        if kind == "finish":  # the run's companions said goodbye; now these and the GCS
            if quiet is not None:
                quiet.run_all()
            for name, core in cores:
                with buffer.lane(name):
                    core.finish(now_s)
            with buffer.lane(roles.gcs):
                gcs.finish(now_s)
            writer.add(in_serial_order([*records, *buffer.take()], order))
            conn.send(("ok", None))
            continue
        writer.add(records)
        if kind == "close":
            return
        inboxes = {name: to_companions[name] + from_sim[name] for name, _ in cores}
        started = time.perf_counter()
        to_sim, to_gcs = _step_companions(routes, roles, cores, inboxes, now_s, buffer)
        writer.times.add("companions", started)
        from_here, records = _answer_and_wait(conn, writer, ("ok", to_sim))
        writer.add(in_serial_order([*records, *buffer.take()], order))  # both processes'
        gcs_inbox = _in_companion_order({**from_here, **to_gcs}, roles.companions)
        gcs_now_s = now_s


def _answer_and_wait(
    conn: multiprocessing.connection.Connection, writer: _Writer, answer: object
) -> Any:
    """Send ``answer`` and return the run's process's next message (``writer`` writing
    records while it waits). A small answer goes before the wait, so that process finds it
    when it asks; a large one (over ``_EARLY_MAX_BYTES``) after, once this side has read:
    two small ones always fit the socket's buffer beside the other side's message, so this
    side never blocks while the other blocks sending to it."""
    blob = bytes(ForkingPickler.dumps(answer))
    if len(blob) <= _EARLY_MAX_BYTES:
        conn.send_bytes(blob)
        return writer.wait_for(conn)
    message = writer.wait_for(conn)
    conn.send_bytes(blob)
    return message


def _step_companions(
    routes: _Routes,
    roles: Roles,
    cores: Sequence[tuple[str, Core]],
    inboxes: dict[str, Datagrams],
    now_s: float,
    buffer: LaneBuffer,
) -> tuple[dict[str, Datagrams], dict[str, Datagrams]]:
    """One tick of ``cores`` (companions), each logging in its own lane; what each sent to
    the sim and what to the GCS, by companion."""
    to_sim: dict[str, Datagrams] = {}
    to_gcs: dict[str, Datagrams] = {}
    for name, core in cores:
        sent: dict[str, Datagrams] = {roles.sim: [], roles.gcs: []}
        with buffer.lane(name):
            routes.split(name, core.handle(now_s, inboxes[name]), sent)
        to_sim[name], to_gcs[name] = sent[roles.sim], sent[roles.gcs]
    return to_sim, to_gcs


def _in_companion_order(by_companion: dict[str, Datagrams], names: Sequence[str]) -> Datagrams:
    """The datagrams of every companion, one after the other in ``names``' order (the order
    the serial router steps them in)."""
    return [datagram for name in names for datagram in by_companion[name]]
