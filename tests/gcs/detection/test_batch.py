"""A cycle's claims through one kernel call give exactly what one call per claim gives, and
the stacked memory behind it grows, keeps every bank's row, and reuses rows of dead banks."""

from __future__ import annotations

import gc

import numpy as np

from ridsafe.gcs.detection.monitor import TransmitterMonitor, observe_batch
from ridsafe.gcs.detection.rssi_consistency import RssiConsistencyDetectors
from ridsafe.gcs.detection.rssi_state import RssiStatePool
from ridsafe.gcs.pipeline_config import DetectionConfig, PipelineConfig
from ridsafe.gcs.synthetic.traffic import Scene, make_traffic


def test_a_batch_equals_one_observe_per_claim_bit_for_bit() -> None:
    """Two pipelines' worth of banks over the same traffic: one sees each cycle's claims in
    one batch (transmitters repeated within a cycle, claims below ``min_receivers``
    included), the other one claim at a time. Every result is equal, not just close."""
    cfg = PipelineConfig(detection=DetectionConfig(min_receivers=8))
    traffic = make_traffic(Scene(seed=4, n_receivers=10, duration_s=12.0, sensitivity_dbm=-75))
    batch_pool, single_pool = RssiStatePool(capacity=2), RssiStatePool(capacity=2)
    batched: dict[str, RssiConsistencyDetectors] = {}
    single: dict[str, RssiConsistencyDetectors] = {}
    cycles = list(traffic.cycles.values())
    batches = [[c for cs in cycles[k : k + 6] for c in cs] for k in range(0, len(cycles), 6)]
    short = repeated = 0
    for claims in batches:
        for c in claims:
            for banks, pool in ((batched, batch_pool), (single, single_pool)):
                if c.uas_id not in banks:
                    banks[c.uas_id] = RssiConsistencyDetectors(c.uas_id, cfg.detection, 1.0, pool)
        got = RssiConsistencyDetectors.observe_batch([batched[c.uas_id] for c in claims], claims)
        want = [single[c.uas_id].observe(c) for c in claims]
        assert got == want
        short += sum(1 for r in got if r == ())
        repeated += len(claims) - len({c.uas_id for c in claims})
    assert repeated > 0  # a bank more than once in a batch
    assert 0 < short < sum(map(len, batches))  # some claims had too few receivers, not all
    assert batch_pool.capacity >= len(batched) > 2  # it grew


def test_the_monitor_batch_runs_every_registry_entry_in_order() -> None:
    cfg = PipelineConfig()
    traffic = make_traffic(Scene(seed=5, n_receivers=6, duration_s=6.0))
    claims = [c for cs in traffic.cycles.values() for c in cs]
    monitors = {c.uas_id: TransmitterMonitor(c.uas_id, cfg) for c in claims}
    reference = {c.uas_id: TransmitterMonitor(c.uas_id, cfg) for c in claims}
    got = observe_batch([monitors[c.uas_id] for c in claims], claims)
    assert got == [reference[c.uas_id].observe(c) for c in claims]
    assert observe_batch([], []) == []


def test_rows_of_collected_banks_are_reused_and_start_empty() -> None:
    pool = RssiStatePool(capacity=1)
    cfg = DetectionConfig()
    first = RssiConsistencyDetectors("A", cfg, 1.0, pool)
    second = RssiConsistencyDetectors("B", cfg, 1.0, pool)  # grows to 2
    assert pool.capacity == 2 and {first.row, second.row} == {0, 1}
    pool.ring_t[second.row] = 5.0
    pool.pair_started[second.row] = True
    row = second.row
    del second
    gc.collect()
    assert pool.in_use == 1
    third = RssiConsistencyDetectors("C", cfg, 1.0, pool)
    assert third.row == row and pool.capacity == 2
    assert np.all(pool.ring_t[row] == -np.inf) and not pool.pair_started[row].any()
    assert first.row != third.row
