"""Coverage-guided fuzzing of one core with atheris (libFuzzer), an optional extra:
``pip install -e '.[fuzz]'``, then

    python -m ridsafe.tools.fuzz.atheris_entry --core sim [libFuzzer flags, e.g. -runs=100000]

The core is warmed up in a lockstep run as in ``harness`` (its captured datagrams are the
seeds); then every libFuzzer input is one datagram to the core at the paused time
(``one_input``): its first byte picks what the rest is, its next two bytes a captured
datagram (whose endpoint, and signing key where the link is keyed, are used):

- first byte even: the rest is sent as it is (raw bytes; libFuzzer's coverage feedback
  steers them past the parser's checks);
- first byte odd: the rest seeds a ``mutate.Mutator`` applied to the captured datagram
  (bytes and decoded field values, CRC and signature recomputed), so the field mutations
  that reach the handlers are explored too.

A crash is an exception out of ``handle`` (atheris stops and writes the input) or a call
over ``SLOW_CALL_MS`` of CPU time (``SlowCallError``). The Hypothesis campaign
(``tests/tools/fuzz``, ``bench/bench_fuzz.py``) needs no extra; this one finds what
coverage feedback finds.
"""

from __future__ import annotations

import argparse
import logging
import random
import re
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the cores are imported under instrumentation, in main
    from ridsafe.tools.fuzz.harness import FuzzRun

__all__ = ["SlowCallError", "compiled_modules", "main", "one_input"]


def compiled_modules() -> list[str]:
    """The ``ridsafe`` modules that mention numba or a jit (kernels, their decorators): left
    uninstrumented, as instrumented bytecode does not compile in nopython mode."""
    root = Path(__file__).resolve().parents[2]
    found = []
    for path in sorted(root.rglob("*.py")):
        if re.search(r"numba|jit", path.read_text(encoding="utf-8")):
            parts = path.relative_to(root.parent).with_suffix("").parts
            found.append(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return found


class SlowCallError(Exception):
    """A core spent more than ``SLOW_CALL_MS`` of CPU time on one datagram."""


def one_input(fuzz_run: FuzzRun, target: str) -> Callable[[bytes], None]:
    """The libFuzzer target for ``target``: one input, one ``handle`` call (module doc)."""
    from ridsafe.tools.fuzz.harness import SLOW_CALL_MS, keyed_signing  # noqa: PLC0415
    from ridsafe.tools.fuzz.mutate import Mutator  # noqa: PLC0415

    name = fuzz_run.core_name(target)
    core = fuzz_run.run.router.cores[name]
    pool = [(endpoint, data) for endpoint, data in fuzz_run.seeds[name] if data]
    if not pool:
        raise ValueError(f"no datagrams captured for {name}: warm up longer")
    now_s = fuzz_run.run.t_s

    def test_one_input(data: bytes) -> None:
        if len(data) < 3:
            return
        endpoint, seed = pool[int.from_bytes(data[1:3], "little") % len(pool)]
        if data[0] % 2 == 0:
            datagram = data[3:]
        else:
            mutator = Mutator(random.Random(data[3:]))
            datagram = mutator.mutate(seed, pool[0][1], keyed_signing(fuzz_run, endpoint))
        cpu0 = time.thread_time()
        core.handle(now_s, [(endpoint, datagram)])
        cpu_ms = (time.thread_time() - cpu0) * 1e3
        if cpu_ms > SLOW_CALL_MS:
            raise SlowCallError(f"{cpu_ms:.0f} ms CPU on {endpoint} for {datagram[:64].hex()}")

    return test_one_input


def main(argv: list[str] | None = None) -> None:
    """Warm up, then hand the target to libFuzzer (the flags it does not know go to it)."""
    import atheris  # noqa: PLC0415 - the optional extra, needed only here

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--core", choices=("sim", "companion", "gcs"), required=True)
    parser.add_argument("--config", help="scenario YAML (default configs/default.yaml)")
    parser.add_argument("--warm-s", type=float, default=12.0, help="clean run before fuzzing")
    parser.add_argument("--planner", default="aware")
    args, libfuzzer_flags = parser.parse_known_args(sys.argv[1:] if argv is None else argv)
    logging.disable(logging.ERROR)  # the cores log every rejection
    with atheris.instrument_imports(include=["ridsafe"], exclude=compiled_modules()):
        from ridsafe.tools.fuzz.harness import warm_up  # noqa: PLC0415
        from ridsafe.tools.run.scenario import load_scenario_file  # noqa: PLC0415

        fuzz_run = warm_up(load_scenario_file(args.config), args.planner, args.warm_s)
    atheris.Setup([sys.argv[0], *libfuzzer_flags], one_input(fuzz_run, args.core))
    atheris.Fuzz()


if __name__ == "__main__":
    main()
