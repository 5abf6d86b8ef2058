"""A short fuzz campaign per core, in the suite (fixed seed, seconds), and the mutator's own
contract: field mutations carry a valid CRC (and signature where keyed), a seed repeats."""

from __future__ import annotations

import random

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ridsafe.common import codec
from ridsafe.common.shell import AppShell
from ridsafe.tools.fuzz.harness import CORES, FuzzRun, warm_up
from ridsafe.tools.fuzz.mutate import Mutator, split_packets
from ridsafe.tools.run.scenario import load_scenario_file

WARM_S = 12.0
SHORT = {"scenario.duration_s": 30.0}


@pytest.fixture(scope="module")
def paused_run() -> FuzzRun:
    return warm_up(load_scenario_file(None, SHORT), "aware", WARM_S)


@pytest.mark.parametrize("core", CORES)
def test_a_short_campaign_crashes_nothing_and_the_core_still_does_its_job(core: str) -> None:
    fuzz_run = warm_up(load_scenario_file(None, SHORT), "aware", WARM_S)
    report = fuzz_run.fuzz_core(core, 1500, random.Random(14))
    fuzz_run.finish_and_check(report)
    assert report.crashes == 0, report.first_crashes
    assert report.hangs == 0
    assert report.still_works, report.job


def test_field_mutations_carry_a_valid_crc_and_signature(paused_run: FuzzRun) -> None:
    signing = paused_run.signing
    assert signing is not None
    seeds = [data for endpoint, data in paused_run.seeds["gcs"] if split_packets(data)]
    mutator = Mutator(random.Random(3))
    receiver = codec.MavlinkLink(255, 190, signing)
    genuine = 0
    for k in range(300):
        mutated = mutator.mutate(seeds[k % len(seeds)], seeds[0], signing)
        genuine += bool(receiver.valid_senders(mutated))
    assert genuine > 100  # the field half, and byte mutations that missed the packets


def test_the_same_seed_gives_the_same_inputs(paused_run: FuzzRun) -> None:
    seeds = [data for _, data in paused_run.seeds["sim"]]

    def inputs(seed: int) -> list[bytes]:
        mutator, rng = Mutator(random.Random(seed)), random.Random(seed + 1)
        return [mutator.mutate(rng.choice(seeds), rng.choice(seeds)) for _ in range(200)]

    assert inputs(5) == inputs(5) != inputs(6)


@settings(max_examples=150, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.binary(max_size=400), index=st.integers(min_value=0))
def test_arbitrary_bytes_on_any_endpoint_never_escape_a_core(
    paused_run: FuzzRun, data: bytes, index: int
) -> None:
    for core_name, seeds in paused_run.seeds.items():
        endpoint = seeds[index % len(seeds)][0]
        core = paused_run.run.router.cores[core_name]
        shell = core.shell  # type: ignore[attr-defined]
        before = _drops_counted(shell), shell.link_totals().accepted
        core.handle(paused_run.run.t_s, [(endpoint, data)])
        after = _drops_counted(shell), shell.link_totals().accepted
        if data and after[1] == before[1]:  # nothing genuine in it: the drop is counted
            assert after[0] > before[0], (core_name, endpoint, data)


def _drops_counted(shell: AppShell) -> int:
    """What the shell publishes in ``/app/counters`` as dropped or refused, summed."""
    refused = shell.counters.unknown_endpoint + sum(shell.counters.refused.values())
    return shell.link_totals().dropped + refused


def test_with_signed_autopilot_links_a_campaign_on_the_sim_is_signed_and_survived() -> None:
    overrides = {**SHORT, "run.sign_autopilot_links": True}
    fuzz_run = warm_up(load_scenario_file(None, overrides), "aware", WARM_S)
    assert fuzz_run.autopilot_signing is not None
    ports = [e.link for name, e in fuzz_run.run.sim.shell.endpoints.items() if "companion" in name]
    before = sum(link.counters.accepted for link in ports)
    report = fuzz_run.fuzz_core("sim", 600, random.Random(15))
    # the field mutations, signed with the key, pass the signature check to the handlers
    assert sum(link.counters.accepted for link in ports) > before + 50
    fuzz_run.finish_and_check(report)
    assert report.crashes == 0, report.first_crashes
    assert report.still_works, report.job
