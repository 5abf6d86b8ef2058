"""Benchmark (not a test): records per second through the MCAP recorder, JSON encoding included.

Writes the record mix of a 16-aircraft, 120 s run (truth at 10 Hz with its derived Foxglove
channels, RID traffic at 1 Hz per aircraft received by every other aircraft, per-reception
detector statistics, observations, planner decisions at 2 Hz per aircraft, GCS cycles, tracks
and regions at 4 Hz: about 100k records), then prints records/s for the whole mix with and
without the Foxglove channels, for each topic alone, the read-back rate and the time
``compute_metrics`` takes on the file, and the JSON encoding alone: the recorder's
(``RecordEncoder``, orjson) against the standard library's encoder it replaced, on the same
records. Target: >= 80k records/s for the mix.

Run: ``.venv/bin/python bench/bench_recorder.py``
"""

from __future__ import annotations

import json
import tempfile
import time
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from ridsafe.common import topics
from ridsafe.tools.analysis.metrics import compute_metrics
from ridsafe.tools.runlog.foxglove_channels import FoxgloveChannels
from ridsafe.tools.runlog.reader import read_records
from ridsafe.tools.runlog.writer import McapRecorder, RecordEncoder

N_BENIGN = 16
SIM_S = 120.0
SPOOFER = N_BENIGN + 1
SERIAL = "RSAF800000666"

Entry = tuple[str, float, dict[str, Any]]


def _meta() -> dict[str, Any]:
    return {
        "mode": "lockstep",
        "seed": 0,
        "planner": "spoofing_aware",
        "scenario": {"scenario": {"origin": {"lat_deg": 36.1, "lon_deg": -86.8, "alt_m": 180}}},
        "aircraft": [
            {
                "sysid": s,
                "serial": f"RSAF8{s:08d}",
                "start_enu_m": [0.0, 0.0, 0.0],
                "goal_enu_m": [300.0, 300.0, 0.0],
                "cruise_alt_m": 60.0,
            }
            for s in range(1, N_BENIGN + 1)
        ],
        "spoofer": {"sysid": SPOOFER, "serial": SERIAL, "offset_enu_m": [50.0, 50.0, 0.0]},
        "adversaries": [],
        "nmac_threshold_m": 50.0,
    }


def _truth(rng: np.random.Generator, t_s: float) -> dict[str, Any]:
    p = rng.uniform([-500, -500, 0], [500, 500, 80], size=(N_BENIGN + 1, 3))
    return {
        "sysid": list(range(1, N_BENIGN + 2)),
        "p_enu_m": p.tolist(),
        "v_enu_m_s": rng.normal(0.0, 4.0, size=(N_BENIGN + 1, 3)).tolist(),
        "armed": [True] * (N_BENIGN + 1),
        "mode": [4] * (N_BENIGN + 1),
        "spoofer_sysid": SPOOFER,
        "spoofer_claimed_p_enu_m": (p[-1] + [50.0, 50.0, 0.0]).tolist(),
        "adversaries": [],
    }


def _per_second(rng: np.random.Generator, t_s: float) -> list[Entry]:
    """One second of RID traffic: every aircraft transmits, all others receive."""
    out: list[Entry] = []
    for sender in range(1, N_BENIGN + 2):
        t = t_s + sender / 20.0
        items = [{"sender": sender, "msg_type": 0}, {"sender": sender, "msg_type": 1}]
        out.append((topics.RADIO_TX, t, {"items": items}))
        rx = [
            {"sender": sender, "receiver": r, "msg_type": 1, "rssi_dbm": float(rng.normal(-70, 5))}
            for r in range(1, N_BENIGN + 1)
            if r != sender
        ]
        out.append((topics.RADIO_RX, t, {"items": rx}))
        for r in rx:
            stat = {
                "uas_id": f"RSAF8{sender:08d}",
                "detector": "kf_nis",
                "statistic": float(rng.chisquare(1)),
                "threshold": 6.63,
                "decision": False,
                "receiver": r["receiver"],
            }
            out.append((topics.DETECTOR_STATS, t + 0.01, stat))
    for sysid in range(1, N_BENIGN + 1):
        item = {
            "t_s": t_s,
            "uas_id": SERIAL,
            "rid_timestamp_s": 1234.5,
            "rssi_dbm": -71.25,
            "rx_lat_deg": 36.1012345,
            "rx_lon_deg": -86.8012345,
            "rx_alt_m": 240.0,
            "claimed_lat_deg": 36.1023456,
            "claimed_lon_deg": -86.8023456,
            "claimed_alt_m": 240.0,
        }
        out.append((topics.OBSERVATIONS, t_s + 0.3, {"sysid": sysid, "items": [item] * 4}))
    return out


def _decision(sysid: int, t_s: float) -> dict[str, Any]:
    return {
        "sysid": sysid,
        "planner": "spoofing_aware",
        "status": "cruise",
        "target_p_ned_m": [12.5, -33.25, -60.0],
        "target_v_ned_m_s": [1.0, 2.0, 0.0],
        "target_lat_deg": 36.1447123,
        "target_lon_deg": -86.8027456,
        "target_alt_m": 240.0,
        "compute_ms": 0.8123,
        "n_neighbours": 5,
        "n_regions": 1,
    }


def _gcs(t_s: float) -> list[Entry]:
    cov = (np.eye(3) * 400.0).tolist()
    track = {
        "uas_id": SERIAL,
        "track_id": 1,
        "p_enu_m": [10.0, 20.0, 60.0],
        "cov_enu_m2": cov,
        "v_enu_m_s": [7.0, 0.0, 0.0],
        "mode_probabilities": [0.4, 0.6],
        "fix": True,
    }
    region = {
        "uas_id": SERIAL,
        "track_id": 1,
        "center_enu_m": [10.0, 20.0, 60.0],
        "cov_enu_m2": cov,
        "chi2_threshold": 7.81,
        "alpha": 0.05,
        "valid_until_s": t_s + 1.0,
        "semi_axes_m": [55.9, 55.9, 55.9],
    }
    cycle = {"compute_ms": 12.5, "n_observations": 60, "n_transmissions": 4, "n_tracks": 17}
    entries: list[Entry] = [(topics.GCS_CYCLE, t_s, cycle), (topics.TRACKS, t_s, track)]
    entries += [(topics.TRACKS, t_s, {**track, "uas_id": f"RSAF8{s:08d}"}) for s in range(1, 17)]
    entries.append((topics.REGIONS, t_s, region))
    return entries


def run_mix() -> list[Entry]:
    rng = np.random.default_rng(1)
    entries: list[Entry] = [(topics.RUN_META, 0.0, _meta())]
    for k in range(round(SIM_S * 10)):
        t_s = k / 10.0
        entries.append((topics.TRUTH, t_s, _truth(rng, t_s)))
        if k % 10 == 0:
            entries += _per_second(rng, t_s)
        if k % 5 == 0:
            entries += [(topics.DECISIONS, t_s, _decision(s, t_s)) for s in range(1, 17)]
    for k in range(round(SIM_S * 4)):
        entries += _gcs(k / 4.0)
    entries.append(
        (
            topics.RUN_END,
            SIM_S,
            {"wall_clock_s": 6.0, "sim_time_s": SIM_S, "status": "completed", "reason": ""},
        )
    )
    entries.sort(key=lambda e: e[1])
    return entries


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
    entries = run_mix()
    counts = Counter(topic for topic, _t, _r in entries)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "run.mcap"
        write(path, entries[:2000], foxglove=True)  # warm-up
        plain = max(write(path, entries, foxglove=False) for _ in range(3))
        full = max(write(path, entries, foxglove=True) for _ in range(3))
        size_mb = path.stat().st_size / 1e6
        t0 = time.perf_counter()
        n_read = sum(1 for _ in read_records(path))
        read_rate = n_read / (time.perf_counter() - t0)
        t0 = time.perf_counter()
        compute_metrics(path)
        metrics_s = time.perf_counter() - t0
        print(
            f"mix of a {N_BENIGN}-aircraft {SIM_S:.0f} s run: {len(entries)} records, "
            f"{size_mb:.1f} MB"
        )
        print(f"  write, Foxglove channels off: {plain:10,.0f} records/s")
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
