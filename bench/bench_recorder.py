"""Benchmark (not a test): records per second through the MCAP recorder, JSON encoding included.

The records are those of a real run: ``configs/paper.yaml`` at 16 aircraft, seed 0, the
aware planner, lockstep in this process, logged once and read back (about 20k records: RID
traffic, observations, detector statistics per claim, planner decisions, GCS cycles, tracks
and regions, truth), less the Foxglove channels, which the recorder's plugin derives again.
Prints records/s for the whole mix with and without the Foxglove channels, for each topic
alone, the read-back rate and the time ``compute_metrics`` takes on the file, and the JSON
encoding alone: the recorder's (``RecordEncoder``, orjson) against the standard library's
encoder it replaced, on the same records. Target: >= 80k records/s for the mix.

Run: ``.venv/bin/python bench/bench_recorder.py``
"""

from __future__ import annotations

import json
import logging
import tempfile
import time
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from ridsafe.tools.analysis.metrics import compute_metrics
from ridsafe.tools.run.lockstep import run_lockstep
from ridsafe.tools.run.scenario import REPO_ROOT, load_scenario_file, with_aircraft
from ridsafe.tools.runlog.foxglove_channels import FoxgloveChannels
from ridsafe.tools.runlog.reader import read_records
from ridsafe.tools.runlog.writer import McapRecorder, RecordEncoder

AIRCRAFT = 16
FOXGLOVE_PREFIX = "/foxglove/"

Entry = tuple[str, float, dict[str, Any]]


def run_mix(folder: Path) -> list[Entry]:
    """Every record a real run logs, as read back, without the derived Foxglove channels
    and without the ``t_s`` the encoder adds to each record itself."""
    loaded = with_aircraft(load_scenario_file(REPO_ROOT / "configs" / "paper.yaml"), AIRCRAFT)
    source = folder / "source.mcap"
    run_lockstep(loaded, "aware", source, recorder_process=False, split=False)
    return [
        (topic, t_s, {k: v for k, v in record.items() if k != "t_s"})
        for topic, t_s, record in read_records(source)
        if not topic.startswith(FOXGLOVE_PREFIX)
    ]


def write(path: Path, entries: list[Entry], *, foxglove: bool) -> float:
    """Records per second for writing ``entries`` (close included)."""
    t0 = time.perf_counter()
    plugins = (FoxgloveChannels(),) if foxglove else ()
    with McapRecorder(path, plugins=plugins) as recorder:
        for topic, t_s, record in entries:
            recorder.log(topic, t_s, record)
    return len(entries) / (time.perf_counter() - t0)


def encode_seconds(entries: list[Entry]) -> tuple[float, float]:
    """(s for the recorder's encoder, s for the standard library's) over ``entries``, best
    of three each; both as the recorder calls them (``t_s`` added, numpy converted)."""
    ours = RecordEncoder()
    standard = json.JSONEncoder(separators=(",", ":"), allow_nan=False, default=_plain)
    best_ours = best_standard = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        for topic, t_s, record in entries:
            ours.encode(topic, t_s, record)
        t1 = time.perf_counter()
        for _topic, t_s, record in entries:
            standard.encode({"t_s": t_s, **record}).encode()
        t2 = time.perf_counter()
        best_ours, best_standard = min(best_ours, t1 - t0), min(best_standard, t2 - t1)
    return best_ours, best_standard


def _plain(value: Any) -> Any:
    return value.tolist() if isinstance(value, np.ndarray) else value.item()


def main() -> None:
    logging.basicConfig(level=logging.ERROR)  # the source run's warnings are not the point
    with tempfile.TemporaryDirectory() as tmp:
        entries = run_mix(Path(tmp))
        counts = Counter(topic for topic, _t, _r in entries)
        path = Path(tmp) / "run.mcap"
        write(path, entries[:2000], foxglove=True)  # warm-up
        plain = max(write(path, entries, foxglove=False) for _ in range(3))
        plain_mb = path.stat().st_size / 1e6
        full = max(write(path, entries, foxglove=True) for _ in range(3))
        size_mb = path.stat().st_size / 1e6
        t0 = time.perf_counter()
        n_read = sum(1 for _ in read_records(path))
        read_rate = n_read / (time.perf_counter() - t0)
        t0 = time.perf_counter()
        compute_metrics(path)
        metrics_s = time.perf_counter() - t0
        print(
            f"the records of a {AIRCRAFT}-aircraft {entries[-1][1]:.0f} s run "
            f"(configs/paper.yaml, seed 0, aware): {len(entries)} records, {plain_mb:.1f} MB "
            f"({size_mb:.1f} MB with the Foxglove channels)"
        )
        plain_mb_s = plain * plain_mb / len(entries)
        print(f"  write, Foxglove channels off: {plain:10,.0f} records/s ({plain_mb_s:.1f} MB/s)")
        print(f"  write, Foxglove channels on:  {full:10,.0f} records/s")
        print(f"  read_records (all {n_read}):  {read_rate:10,.0f} records/s")
        print(f"  compute_metrics:              {metrics_s:10.3f} s")
        ours_s, standard_s = encode_seconds(entries)
        print(
            f"  JSON encoding alone: the recorder's {ours_s:.3f} s, the standard library's "
            f"{standard_s:.3f} s ({standard_s / ours_s:.1f}x)"
        )
        print("per topic (Foxglove off):")
        for topic, n in counts.most_common():
            subset = [e for e in entries if e[0] == topic]
            rate = write(Path(tmp) / "topic.mcap", subset, foxglove=False)
            print(f"  {topic:<26} {n:7d} records  {rate:10,.0f} records/s")


if __name__ == "__main__":
    main()
