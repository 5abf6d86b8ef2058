"""A fuzz campaign against one core of a real lockstep run, then a check that it still works.

1. **Seeds from a real run** (``warm_up``): the scenario's cores are built by the factory and
   run in lockstep for ``warm_s``; every datagram each core receives is recorded, by
   endpoint. Nothing is committed: the corpus is made at run time.
2. **Fuzz** (``fuzz_core``): with the run paused at ``warm_s``, the target core (``sim``,
   ``companion``, ``gcs``) is fed ``n`` mutated datagrams (``mutate.Mutator``; signed with
   the run's key on keyed links), one ``handle`` call each at the paused time (the objects
   built so far frozen out of the garbage collector's reach first, as every app does before
   its run starts); what it sends
   is dropped (as if lost). Counted: crashes (an exception out of ``handle``), calls over
   ``SLOW_CALL_MS`` (100 ms) and over ``HANG_CALL_MS`` (1 s) of the thread's CPU time, the
   slowest call; wall times beside them (``_call`` says why CPU time judges).
3. **Still works** (``finish_and_check``): the whole run goes on, clean, to the scenario's
   end; the fuzzed core must still do its job: the sim still flies (telemetry reaches every
   companion after the campaign), the companion still plans (decisions after the campaign,
   or its mission done), the GCS still tracks (cycles and regions after the campaign). The
   missions' phases are reported too.
"""

from __future__ import annotations

import gc
import random
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from ridsafe.common.codec import SigningConfig
from ridsafe.common.logsink import NullSink
from ridsafe.common.runner import freeze_startup_objects
from ridsafe.common.shell import Datagrams, SansIoCore
from ridsafe.tools.fuzz.mutate import Mutator
from ridsafe.tools.run import lockstep
from ridsafe.tools.run.scenario import ScenarioFile

__all__ = ["CORES", "SLOW_CALL_MS", "FuzzReport", "FuzzRun", "keyed_signing", "warm_up"]

SLOW_CALL_MS = 100.0
HANG_CALL_MS = 1000.0
CORES = ("sim", "companion", "gcs")
_KEYED_ENDPOINTS = ("gcs", "companions@")  # the companion's GCS link, the GCS's peer links


@dataclass
class FuzzReport:
    core: str
    inputs: int = 0
    seconds: float = 0.0
    crashes: int = 0
    slow_calls: int = 0  # CPU time over SLOW_CALL_MS
    hangs: int = 0  # CPU time over HANG_CALL_MS
    slowest_ms: float = 0.0  # CPU time of the slowest call
    slow_calls_wall: int = 0  # wall time over SLOW_CALL_MS (preemption included)
    slow_calls_gc: int = 0  # slow calls that are slow only by a garbage collection in them
    slowest_wall_ms: float = 0.0
    first_crashes: list[str] = field(default_factory=list)
    first_slow: list[str] = field(default_factory=list)  # the first slow calls' inputs
    still_works: bool | None = None
    job: str = ""

    @property
    def inputs_per_s(self) -> float:
        return self.inputs / self.seconds if self.seconds > 0 else 0.0


class _Recorder:
    """A core that records what it is handed, then hands it on."""

    def __init__(self, core: SansIoCore, into: Datagrams) -> None:
        self.core, self.into = core, into

    def handle(self, now_s: float, inbound: Datagrams) -> Datagrams:
        self.into.extend(inbound)
        return self.core.handle(now_s, inbound)


class _GcTimer:
    """The CPU time the interpreter's garbage collections took since the last ``take_ms``
    (a generation-2 collection walks every object of the process, whatever the input)."""

    installed: _GcTimer | None = None

    def __init__(self) -> None:
        self._start_s = 0.0
        self._total_s = 0.0

    def __call__(self, phase: str, info: dict[str, int]) -> None:
        if phase == "start":
            self._start_s = time.thread_time()
        else:
            self._total_s += time.thread_time() - self._start_s

    def take_ms(self) -> float:
        total, self._total_s = self._total_s, 0.0
        return total * 1e3


@dataclass
class FuzzRun:
    """A lockstep run paused at ``warm_s`` with the datagrams each core received so far."""

    run: lockstep.Lockstep
    seeds: dict[str, Datagrams]
    signing: SigningConfig | None  # the GCS links'
    duration_s: float
    autopilot_signing: SigningConfig | None = None  # with ``run.sign_autopilot_links``

    def core_name(self, target: str) -> str:
        if target == "companion":
            return lockstep.companion_core(min(self.run.companions))
        if target not in ("sim", "gcs"):
            raise ValueError(f"unknown core {target!r}; expected one of {CORES}")
        return target

    def fuzz_core(
        self,
        target: str,
        n: int,
        rng: random.Random,
        progress: Callable[[FuzzReport], None] | None = None,
        progress_every: int = 100_000,
        batch: int = 1,
    ) -> FuzzReport:
        """Feed ``n`` mutated datagrams to ``target`` at the paused time (module docstring);
        ``progress`` is handed the report so far every ``progress_every`` inputs.

        ``batch`` datagrams go in one ``handle`` call, as a UDP runner hands a core what
        arrived since its last step: the core's per-call work (the sim steps its world each
        call) is paid once per batch. The call's time bounds each of its inputs' from above,
        so slow calls and hangs are counted per call (conservatively); a crash is one per
        call (the shell contains the handlers' errors, so any crash is what matters)."""
        if batch < 1:
            raise ValueError(f"batch must be at least 1, got {batch}")
        name = self.core_name(target)
        core = self.run.router.cores[name]
        pool = [
            (endpoint, data, keyed_signing(self, endpoint))
            for endpoint, data in self.seeds[name]
            if data
        ]  # the signing of each seed's link looked up once, not per input
        if not pool:
            raise ValueError(f"no datagrams captured for {name}: warm up longer")
        mutator, report, now_s = Mutator(rng), FuzzReport(target), self.run.t_s
        freeze_startup_objects()  # as every app does before its run starts
        start = time.perf_counter()
        inbound: Datagrams = []
        for k in range(1, n + 1):
            endpoint, seed, signing = rng.choice(pool)
            inbound.append((endpoint, mutator.mutate(seed, rng.choice(pool)[1], signing)))
            if len(inbound) == batch or k == n:
                self._call(report, core, now_s, inbound)
                inbound = []
            if progress is not None and k % progress_every == 0 and k < n:
                report.inputs, report.seconds = k, time.perf_counter() - start
                progress(report)
        report.inputs, report.seconds = n, time.perf_counter() - start
        return report

    @property
    def _gc_timer(self) -> _GcTimer:
        timer = _GcTimer.installed
        if timer is None:
            timer = _GcTimer.installed = _GcTimer()
            gc.callbacks.append(timer)
        return timer

    def _call(self, report: FuzzReport, core: SansIoCore, now_s: float, inbound: Datagrams) -> None:
        """One ``handle`` call, timed twice: the thread's CPU time judges slow calls and hangs
        (the core's own work), the wall time is reported beside it (on a shared machine it
        also holds the time the process waited for a CPU); the garbage collections inside
        the call are timed too, so a call slow only by one is told apart."""
        self._gc_timer.take_ms()  # collections before the call are not the call's
        t0, cpu0 = time.perf_counter(), time.thread_time()
        try:
            core.handle(now_s, inbound)
        except Exception as exc:  # what the campaign is looking for: counted, kept
            report.crashes += 1
            if len(report.first_crashes) < 5:
                report.first_crashes.append(f"{type(exc).__name__}: {exc}")
        cpu_ms = (time.thread_time() - cpu0) * 1e3
        wall_ms = (time.perf_counter() - t0) * 1e3
        report.slowest_ms = max(report.slowest_ms, cpu_ms)
        report.slowest_wall_ms = max(report.slowest_wall_ms, wall_ms)
        report.slow_calls += cpu_ms > SLOW_CALL_MS
        report.hangs += cpu_ms > HANG_CALL_MS
        gc_ms = self._gc_timer.take_ms()
        report.slow_calls_gc += cpu_ms > SLOW_CALL_MS >= cpu_ms - gc_ms
        report.slow_calls_wall += wall_ms > SLOW_CALL_MS
        if cpu_ms > SLOW_CALL_MS and len(report.first_slow) < 5:
            endpoint, data = inbound[0]
            report.first_slow.append(
                f"{cpu_ms:.0f} ms CPU ({gc_ms:.0f} ms of it in gc) on {endpoint}: {data[:48].hex()}"
            )

    def finish_and_check(self, report: FuzzReport) -> FuzzReport:
        """Run on, clean, to the end; judge whether the fuzzed core still does its job."""
        fuzz_end_s = self.run.t_s
        gcs = self.run.gcs
        cycles, regions = gcs.counters.cycles, gcs.counters.regions_sent
        decisions = {s: c.pilot.counters.decisions for s, c in self.run.companions.items()}
        while self.run.t_s < self.duration_s - 1e-9:
            self.run.step()
        self.run.finish()
        phases = {s: c.phase.value for s, c in self.run.companions.items()}
        if report.core == "sim":
            fresh = [c.own.gpi_s > fuzz_end_s + 1.0 for c in self.run.companions.values()]
            report.still_works = all(fresh)
            report.job = f"telemetry after the campaign to {sum(fresh)}/{len(fresh)} companions"
        elif report.core == "companion":
            sysid = min(self.run.companions)
            companion = self.run.companions[sysid]
            planned = companion.pilot.counters.decisions - decisions[sysid]
            report.still_works = planned > 0 or companion.phase.value == "done"
            report.job = f"{planned} decisions after the campaign"
        else:
            new_cycles = gcs.counters.cycles - cycles
            new_regions = gcs.counters.regions_sent - regions
            report.still_works = new_cycles > 0 and new_regions > 0
            report.job = f"{new_cycles} cycles, {new_regions} regions after the campaign"
        report.job += f"; missions {phases}"
        return report


def keyed_signing(fuzz_run: FuzzRun, endpoint: str) -> SigningConfig | None:
    """The signing an attacker with the key uses on ``endpoint``: the run's on keyed links
    (the GCS links; the autopilot links too when they are signed)."""
    if endpoint.startswith(_KEYED_ENDPOINTS):
        return fuzz_run.signing
    if endpoint == "autopilot" or endpoint.endswith("/companion"):
        return fuzz_run.autopilot_signing
    return None


def warm_up(loaded: ScenarioFile, planner: str, warm_s: float) -> FuzzRun:
    """Build the scenario's cores and run them clean for ``warm_s``, recording every
    datagram each core receives (the seed corpus)."""
    run = lockstep.build(loaded, planner, NullSink())
    seeds: dict[str, Datagrams] = {name: [] for name in run.router.cores}
    originals = dict(run.router.cores)
    for name, core in originals.items():
        run.router.cores[name] = _Recorder(core, seeds[name])
    while run.t_s < warm_s - 1e-9:
        run.step()
    run.router.cores.update(originals)
    signing = lockstep.lockstep_signing(loaded)
    autopilot_signing = lockstep.lockstep_autopilot_signing(loaded)
    return FuzzRun(run, seeds, signing, loaded.scenario.duration_s, autopilot_signing)
