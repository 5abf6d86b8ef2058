r"""Who did not hear it: the evidence a censored channel's misses hold about a claimed position.

A receiver reports nothing weaker than its sensitivity ``f``. Where the cut binds (a
path-loss exponent of 3 puts a 20 dBm transmitter at -95 dBm about 320 m away), the fleet
receivers that did *not* report a transmission say as much as those that did: a claim that
puts the transmitter near a listening receiver that heard nothing is unlikely. The detectors
in ``gcs/detection/`` test only the receptions reported (with the lift above the cut
corrected, ``gcs/calibration/censoring.py``); this tool measures, on a run's log, what a test
that also counts the misses would see.

The model, over one transmitter's claims of the last ``window_s`` seconds, each heard or not
by every listening fleet receiver i (positions r_i), the claim at c::

    mu_i = P - 10 n log10(max(||c - delta - r_i||, 1))       (P: power less the 1 m loss)
    heard with RSSI z_i:  density (1 - q) phi((z_i - mu_i) / s) / s
    not heard:            q + (1 - q) Phi((f - mu_i) / s)

with q a miss probability the channel always has (packet loss; ``--miss-floor``). The test is
the generalised likelihood ratio of a common offset delta (the transmitter is not where it
claims) against delta = 0, the power P free in both: T = 2 (max l(delta, P) - max l(0, P)),
about chi2_3 under an honest claim, reported as surprisal -log10 p against the detectors'
threshold (-log10 1e-6 = 6).

What the GCS would know is taken from the log: the channel (n, s) of its fit
(``/gcs/channel``, the latest at the claim, the first for the claims it held before its
fit); the sensitivity as the weakest RSSI a fleet receiver heard so far (as
``SensitivityFloor``: the spoofer's own radio reports to no one, and early in a run its
receptions can be a dB weaker than any the fleet has); the listening receivers as every
fleet aircraft. What it is given here from the simulator: the
receivers' and the claims' positions (``/truth/vehicles``; the spoofer's claim is its truth
plus its ``/run/meta`` offset), where the GCS has its aircraft's reports, and receivers
without RSSI biases (the fit's biases are not logged). So this measures the misses'
evidence on an accurately fitted channel, not a detector the GCS runs: it runs none.

``python -m ridsafe.tools.analysis.censored_evidence LOG...`` prints per run, with the misses
and on the receptions alone: when the spoofer's statistic first crosses the threshold, the
detection delay that gives (no earlier than the GCS's first fit; after four aircraft heard
the spoofer, as the metrics count it), and the largest honest statistic (every other
transmitter, every ``--every-s`` seconds); then their median, 90th percentile and worst over
the runs.
"""

from __future__ import annotations

import argparse
import bisect
import math
import sys
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

from ridsafe.common import topics
from ridsafe.common.mav_enums import OdidMessageType
from ridsafe.gcs.detection import censored_kernels
from ridsafe.gcs.detection.censored import SEARCH_GRID_ENU_M
from ridsafe.tools.analysis.detection_bound import delay_summary
from ridsafe.tools.analysis.run_arrays import DETECTION_RECEIVERS
from ridsafe.tools.runlog.reader import LogReadError, read_records

__all__ = [
    "CensoredChannel",
    "Heard",
    "RunEvidence",
    "offset_glrt",
    "run_evidence",
]

FloatArray = NDArray[np.float64]

_LN10 = math.log(10.0)


@dataclass(frozen=True)
class CensoredChannel:
    """Log-distance path loss with exponent ``exponent``, Gaussian noise ``sigma_db``, nothing
    reported below ``floor_dbm``, and a miss probability ``miss_floor`` above it."""

    exponent: float
    sigma_db: float
    floor_dbm: float
    miss_floor: float = 0.01

    def __post_init__(self) -> None:
        if not 0.0 < self.miss_floor < 1.0:
            raise ValueError(f"miss floor: expected 0 < q < 1, got {self.miss_floor:g}")
        if not self.sigma_db > 0.0:
            raise ValueError(f"sigma: expected > 0 dB, got {self.sigma_db:g}")


@dataclass(frozen=True)
class Heard:
    """One transmission as every listening receiver saw it: the claimed position (3,), the
    receivers' positions (m, 3), whether each heard it (m,) and its RSSI (m,; NaN if not)."""

    claimed_p_enu_m: FloatArray
    rx_p_enu_m: FloatArray
    heard: NDArray[np.bool_]
    rssi_dbm: FloatArray


def offset_glrt(window: Sequence[Heard], channel: CensoredChannel, misses: bool = True) -> float:
    """T = 2 (max l(delta, P) - max l(0, P)) over the window (module docstring;
    ``gcs/detection/censored_kernels.py``); 0 when no receiver heard any of it. Without
    ``misses`` only the receptions count, each given that it was heard (what a test of the
    receptions alone, their lift accounted for, has)."""
    if not window:
        return 0.0
    diff = np.concatenate([tx.claimed_p_enu_m - tx.rx_p_enu_m for tx in window])
    heard = np.concatenate([tx.heard for tx in window])
    rssi = np.where(heard, np.concatenate([tx.rssi_dbm for tx in window]), 0.0)
    floor = np.full(heard.shape[0], channel.floor_dbm)
    return censored_kernels.offset_glrt(
        diff,
        heard,
        rssi,
        floor,
        channel.exponent,
        np.full(heard.shape[0], channel.sigma_db),
        channel.miss_floor,
        misses,
        SEARCH_GRID_ENU_M,
    )


def surprisal(statistic: float) -> float:
    """-log10 of the chi2_3 tail beyond ``statistic``."""
    return float(-chi2.logsf(statistic, 3) / _LN10)


@dataclass(frozen=True)
class RunEvidence:
    """One run: when the GCS first fitted, when four aircraft had heard the spoofer, when its
    statistic first crossed the threshold with the misses and on the receptions alone (None:
    not in the span tested), and the largest honest surprisal, likewise."""

    fit_s: float
    heard_by_s: float | None
    crossed_s: float | None
    crossed_received_only_s: float | None
    honest_max: float
    honest_max_received_only: float

    def delay_s(self, crossed_s: float | None) -> float:
        """Detection delay after four heard it, no earlier than the fit (inf: never)."""
        if self.heard_by_s is None or crossed_s is None:
            return math.inf
        return max(crossed_s, self.fit_s) - self.heard_by_s


@dataclass
class _Log:
    spoofer: int
    offset: FloatArray
    truth_t: list[float]
    truth_p: list[FloatArray]
    column: dict[int, int]
    #: sender -> [(t_s, {receiver: rssi})] of its LOCATION messages, in time order
    sent: dict[int, list[tuple[float, dict[int, float]]]]
    floor_t: list[float]
    floor_dbm: list[float]  # the weakest RSSI reported up to floor_t
    channel_t: list[float]
    channel: list[tuple[float, float]]  # (exponent, sigma_db) of each fit


def _read(log: Path) -> _Log:
    out = _Log(0, np.zeros(3), [], [], {}, {}, [], [], [], [])
    meta_seen = False
    weakest = math.inf
    wanted = (topics.RUN_META, topics.TRUTH, topics.RADIO_RX, topics.GCS_CHANNEL)
    for topic, t_s, record in read_records(log, topics=wanted):
        if topic == topics.RUN_META:
            out.spoofer, out.offset = _spoofer_of(log, record)
            meta_seen = True
        elif topic == topics.GCS_CHANNEL:
            if record.get("exponent") is not None:
                out.channel_t.append(t_s)
                out.channel.append((float(record["exponent"]), float(record["sigma_db"])))
        elif topic == topics.TRUTH:
            out.truth_t.append(t_s)
            out.truth_p.append(np.asarray(record["p_enu_m"], dtype=np.float64))
            out.column = {int(s): k for k, s in enumerate(record["sysid"])}
        elif not meta_seen:
            raise ValueError(f"{log}: receptions before {topics.RUN_META}")
        else:
            weakest = _add_receptions(out, t_s, record.get("items") or (), weakest)
    if not meta_seen:
        raise ValueError(f"{log}: no spoofer with a constant offset in {topics.RUN_META}")
    if not out.channel:
        raise ValueError(f"{log}: no fitted channel in {topics.GCS_CHANNEL} (calibration off?)")
    return out


def _spoofer_of(log: Path, meta: dict[str, Any]) -> tuple[int, FloatArray]:
    """The spoofer's system id and its constant claimed offset (m, ENU) from the run's meta."""
    spoofer = meta.get("spoofer")
    if not isinstance(spoofer, dict) or "offset_enu_m" not in spoofer:
        raise ValueError(f"{log}: no spoofer with a constant offset in {topics.RUN_META}")
    return int(spoofer["sysid"]), np.asarray(spoofer["offset_enu_m"], dtype=np.float64)


def _add_receptions(out: _Log, t_s: float, items: Sequence[Any], weakest_dbm: float) -> float:
    """Add one ``/radio/receptions`` record's LOCATION receptions to ``out.sent`` and the
    cut as of ``t_s``: the weakest RSSI a fleet receiver heard so far (the spoofer's own
    radio reports to no one). Returns that weakest RSSI."""
    for item in items:
        receiver, rssi_dbm = int(item["receiver"]), float(item["rssi_dbm"])
        if receiver != out.spoofer:
            weakest_dbm = min(weakest_dbm, rssi_dbm)
        if int(item["msg_type"]) != OdidMessageType.LOCATION:
            continue
        sent = out.sent.setdefault(int(item["sender"]), [])
        if not sent or sent[-1][0] != t_s:
            sent.append((t_s, {}))
        sent[-1][1][receiver] = rssi_dbm
    out.floor_t.append(t_s)
    out.floor_dbm.append(weakest_dbm)
    return weakest_dbm


def _heard(log: _Log, sender: int, t_s: float, receptions: dict[int, float]) -> Heard:
    k = min(bisect.bisect_left(log.truth_t, t_s), len(log.truth_t) - 1)
    p = log.truth_p[k]
    claimed = p[log.column[sender]] + (log.offset if sender == log.spoofer else 0.0)
    receivers = [s for s in log.column if s not in (sender, log.spoofer)]
    rx = p[[log.column[s] for s in receivers]]
    rssi = np.array([receptions.get(s, math.nan) for s in receivers])
    return Heard(claimed, rx, ~np.isnan(rssi), rssi)


def _channel_at(log: _Log, t_s: float, miss_floor: float) -> CensoredChannel:
    """The GCS's fit in force at ``t_s`` (its first for claims before it) and the floor."""
    k = max(bisect.bisect_right(log.channel_t, t_s) - 1, 0)
    exponent, sigma_db = log.channel[k]
    f = max(bisect.bisect_right(log.floor_t, t_s) - 1, 0)
    return CensoredChannel(exponent, sigma_db, log.floor_dbm[f], miss_floor)


def _windows(
    log: _Log, sender: int, window_s: float, every_s: float, until_s: float
) -> Iterator[tuple[float, list[Heard]]]:
    """Each ``every_s`` seconds up to ``until_s``: the sender's window of transmissions."""
    sent = log.sent.get(sender, [])
    last = -math.inf
    for k, (t_s, _) in enumerate(sent):
        if t_s > until_s:
            return
        if t_s - last < every_s:
            continue
        last = t_s
        window = [_heard(log, sender, t, r) for t, r in sent[: k + 1] if t > t_s - window_s]
        yield t_s, window


def run_evidence(
    path: Path,
    *,
    window_s: float = 10.0,
    until_s: float = 30.0,
    every_s: float = 1.0,
    threshold: float = 6.0,
    miss_floor: float = 0.01,
) -> RunEvidence:
    """The misses' evidence in one log (module docstring)."""
    log = _read(path)
    heard: set[int] = set()
    heard_by: float | None = None
    for t_s, receptions in log.sent.get(log.spoofer, []):
        heard.update(receptions)
        if len(heard) >= DETECTION_RECEIVERS:
            heard_by = t_s
            break
    crossed: dict[bool, float | None] = {True: None, False: None}
    for misses in crossed:
        for t_s, window in _windows(log, log.spoofer, window_s, 0.0, until_s):
            channel = _channel_at(log, t_s, miss_floor)
            if surprisal(offset_glrt(window, channel, misses)) > threshold:
                crossed[misses] = t_s
                break
    honest_max = {True: 0.0, False: 0.0}
    for sender in log.sent:
        if sender == log.spoofer:
            continue
        for t_s, window in _windows(log, sender, window_s, every_s, until_s):
            channel = _channel_at(log, t_s, miss_floor)
            for misses, worst in honest_max.items():
                honest_max[misses] = max(worst, surprisal(offset_glrt(window, channel, misses)))
    return RunEvidence(
        log.channel_t[0],
        heard_by,
        crossed[True],
        crossed[False],
        honest_max[True],
        honest_max[False],
    )


def _time(t_s: float | None) -> str:
    return "never" if t_s is None else f"{t_s:.2f}"


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("logs", nargs="+", type=Path, metavar="LOG")
    parser.add_argument("--window-s", type=float, default=10.0, help="the test's window (s)")
    parser.add_argument("--until-s", type=float, default=30.0, help="test claims up to S seconds")
    parser.add_argument("--every-s", type=float, default=1.0, help="honest claims tested (s)")
    parser.add_argument("--threshold", type=float, default=6.0, help="surprisal")
    parser.add_argument("--miss-floor", type=float, default=0.01, help="q, a miss's floor")
    args = parser.parse_args(argv)
    runs: list[RunEvidence] = []
    print(
        "log | GCS fit (s) | heard by 4 (s) | crossed, with misses / received only (s) | "
        "delay, with misses / received only (s) | honest max, with misses / received only "
        "(surprisal)"
    )
    for log in args.logs:
        try:
            ev = run_evidence(
                log,
                window_s=args.window_s,
                until_s=args.until_s,
                every_s=args.every_s,
                threshold=args.threshold,
                miss_floor=args.miss_floor,
            )
        except (ValueError, KeyError, OSError, LogReadError) as exc:
            print(f"censored_evidence: {exc}", file=sys.stderr)
            return 2
        runs.append(ev)
        print(
            f"{log} | {_time(ev.fit_s)} | {_time(ev.heard_by_s)} | {_time(ev.crossed_s)} / "
            f"{_time(ev.crossed_received_only_s)} | {ev.delay_s(ev.crossed_s):.2f} / "
            f"{ev.delay_s(ev.crossed_received_only_s):.2f} | {ev.honest_max:.2f} / "
            f"{ev.honest_max_received_only:.2f}",
            flush=True,
        )
    with_misses = delay_summary([ev.delay_s(ev.crossed_s) for ev in runs])
    received_only = delay_summary([ev.delay_s(ev.crossed_received_only_s) for ev in runs])
    print(
        f"{len(runs)} runs, tested up to {args.until_s:g} s: delay median / p90 / worst "
        f"{with_misses} s with the misses, {received_only} s on the receptions alone"
    )
    for name, honest in (
        ("with the misses", [ev.honest_max for ev in runs]),
        ("on the receptions alone", [ev.honest_max_received_only for ev in runs]),
    ):
        over = sum(h > args.threshold for h in honest)
        print(
            f"  largest honest surprisal {name}, median / p90 / worst over runs: "
            f"{delay_summary(honest)} ({over} runs over {args.threshold:g})"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
