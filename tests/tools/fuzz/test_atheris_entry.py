"""The atheris entry point: its target turns libFuzzer inputs into datagrams a core survives,
and (where the optional extra is installed) a short libFuzzer run over a core finds nothing."""

from __future__ import annotations

import random
import subprocess
import sys

import pytest

from ridsafe.tools.fuzz.atheris_entry import one_input
from ridsafe.tools.fuzz.harness import CORES, warm_up
from ridsafe.tools.run.scenario import load_scenario_file
from tests.tools.run.live_runs import ROOT


@pytest.mark.parametrize("core", CORES)
def test_the_target_takes_raw_and_mutated_inputs_without_an_escape(core: str) -> None:
    fuzz_run = warm_up(load_scenario_file(None, {"scenario.duration_s": 12.0}), "aware", 6.0)
    target = one_input(fuzz_run, core)
    shell = fuzz_run.run.router.cores[fuzz_run.core_name(core)].shell  # type: ignore[attr-defined]
    before = shell.counters.datagrams_in
    rng = random.Random(2)
    inputs = [bytes([k % 2]) + rng.randbytes(rng.randint(2, 200)) for k in range(400)]
    for data in [b"", b"\x01", *inputs]:
        target(data)
    assert shell.counters.datagrams_in - before == len(inputs)


def test_a_short_libfuzzer_run_over_the_gcs_finds_nothing() -> None:
    pytest.importorskip("atheris")
    argv = [sys.executable, "-m", "ridsafe.tools.fuzz.atheris_entry", "--core", "gcs"]
    done = subprocess.run(
        [*argv, "--warm-s", "6", "-runs=3000", "-seed=14"],
        check=False,
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert "Done 3000 runs" in done.stderr
