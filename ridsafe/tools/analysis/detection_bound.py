r"""The detection delay no detector can beat on a run's geometry: an oracle bound.

An oracle that knows where the spoofer truly is runs the most powerful test (Neyman-Pearson)
of "the transmitter is at its claimed position c" against "it is at its true position p" on
the spoofer's receptions in the log (``/radio/receptions``; receivers and spoofer from
``/truth/vehicles``; the claim is the truth plus the ``/run/meta`` spoofer's constant
``offset_enu_m``). The channel is the model the GCS assumes: RSSI = P - 10 n log10 d + e, e
i.i.d. N(0, sigma^2), the transmit power P unknown but constant. Over every reception j so
far, with g_j = -10 log10 d_j::

    lambda(t) = (n / sigma)^2 * || Pi (g(p) - g(c)) ||^2

(Pi removes the common mean: the unknown power). The test at false-alarm probability alpha
detects with probability beta once sqrt(lambda) >= z(1 - alpha) + z(beta); the time that
takes after four aircraft heard the spoofer is a lower bound on any detector's delay at that
false-alarm rate with that probability (a real detector does not know p, and pays for it).
Noise that is not i.i.d., or a path-loss exponent the GCS must estimate, only make it worse.

It is a bound only where the receivers' sensitivity does not bind on the spoofer's links
(every link's mean well above the cut: exponent 2 over the paper's square kilometre). Where
it does (exponent 3 puts 20 dBm at -95 dBm about 320 m away) the receptions reported are a
censored sample, which this oracle takes for an uncensored one, and the receivers that did
not hear a transmission carry evidence it does not count: on exponent 3 at 16 aircraft a
censored likelihood-ratio test on the GCS's own fit crossed its threshold before this
"bound" in some runs (``censored_evidence.py``; docs/results/robustness.md).

``python -m ridsafe.tools.analysis.detection_bound LOG...`` prints, per channel (n, sigma),
the bound's median, 90th percentile and worst over the logs.
"""

from __future__ import annotations

import argparse
import bisect
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.special import ndtri

from ridsafe.common import topics
from ridsafe.tools.analysis.run_arrays import DETECTION_RECEIVERS
from ridsafe.tools.runlog.reader import LogReadError, read_records

__all__ = [
    "SeparationCurve",
    "delay_summary",
    "detection_bound_s",
    "required_lambda",
    "separation_curve",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class SeparationCurve:
    """Lambda per unit (n / sigma)^2 after each reception batch, and when four had heard."""

    t_s: FloatArray
    unit_lambda: FloatArray  # || Pi (g(p) - g(c)) ||^2 over every reception up to t_s, dB^2
    heard_by_s: float | None


def required_lambda(false_alarm: float, detection: float) -> float:
    """The noncentrality a one-sided test at ``false_alarm`` needs to detect with
    probability ``detection``: (z(1 - false_alarm) + z(detection))^2."""
    return float((ndtri(1.0 - false_alarm) + ndtri(detection)) ** 2)


def separation_curve(log: Path) -> SeparationCurve:
    """The spoofer's receptions in ``log`` as the oracle's evidence over time."""
    meta: dict[str, object] = {}
    truth_t: list[float] = []
    truth_p: list[FloatArray] = []
    column: dict[int, int] = {}
    receptions: dict[tuple[float, int, int], list[int]] = {}  # (t_s, type, sender) -> rx
    for topic, t_s, record in read_records(
        log, topics=(topics.RUN_META, topics.TRUTH, topics.RADIO_RX)
    ):
        if topic == topics.RUN_META:
            meta = record
        elif topic == topics.TRUTH:
            truth_t.append(t_s)
            truth_p.append(np.asarray(record["p_enu_m"], dtype=np.float64))
            column = {int(s): k for k, s in enumerate(record["sysid"])}
        else:
            for item in record.get("items") or ():
                key = (t_s, int(item["msg_type"]), int(item["sender"]))
                receptions.setdefault(key, []).append(int(item["receiver"]))
    spoofer = meta.get("spoofer")
    if not isinstance(spoofer, dict) or "offset_enu_m" not in spoofer:
        raise ValueError(f"{log}: no spoofer with a constant offset in {topics.RUN_META}")
    offset = np.asarray(spoofer["offset_enu_m"], dtype=np.float64)
    sysid = int(spoofer["sysid"])
    me = column[sysid]
    heard: set[int] = set()
    heard_by: float | None = None
    s1 = s2 = 0.0
    n = 0
    times: list[float] = []
    lambdas: list[float] = []
    for (t_s, _msg, sender), receivers in sorted(receptions.items()):
        if sender != sysid:
            continue
        k = min(bisect.bisect_left(truth_t, t_s), len(truth_t) - 1)
        p = truth_p[k]
        heard.update(receivers)
        if heard_by is None and len(heard) >= DETECTION_RECEIVERS:
            heard_by = t_s
        r = p[[column[s] for s in receivers]]
        true_d = np.linalg.norm(p[me] - r, axis=1)
        claim_d = np.linalg.norm(p[me] + offset - r, axis=1)
        d = 10.0 * np.log10(np.maximum(claim_d, 1.0) / np.maximum(true_d, 1.0))
        s1, s2, n = s1 + float(d.sum()), s2 + float(d @ d), n + d.size
        times.append(t_s)
        lambdas.append(s2 - s1 * s1 / n)
    return SeparationCurve(np.asarray(times), np.asarray(lambdas), heard_by)


def detection_bound_s(
    curve: SeparationCurve, exponent: float, sigma_db: float, needed_lambda: float
) -> float:
    """Seconds after four aircraft heard the spoofer until lambda reaches ``needed_lambda``
    (inf: never in the log)."""
    if curve.heard_by_s is None:
        return math.inf
    scaled = (exponent / sigma_db) ** 2 * curve.unit_lambda
    hit = np.flatnonzero(scaled >= needed_lambda)
    return float(curve.t_s[hit[0]] - curve.heard_by_s) if hit.size else math.inf


def delay_summary(values: Sequence[float]) -> str:
    """Median / 90th percentile / worst, each one of the values (inf: never in the log)."""
    a = np.asarray(values)
    picked = np.quantile(a, (0.5, 0.9, 1.0), method="inverted_cdf")
    return " / ".join("never" if math.isinf(v) else f"{v:.1f}" for v in picked)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("logs", nargs="+", type=Path, metavar="LOG")
    parser.add_argument("--exponents", default="2,3", help="path-loss exponents, e.g. 2,3")
    parser.add_argument("--sigmas", default="1,2,4,6", help="noise std (dB), e.g. 1,2,4,6")
    parser.add_argument("--false-alarm", type=float, default=1e-6)
    parser.add_argument("--detection", type=float, default=0.5)
    args = parser.parse_args(argv)
    needed = required_lambda(args.false_alarm, args.detection)
    try:
        curves = [separation_curve(log) for log in args.logs]
    except (ValueError, KeyError, OSError, LogReadError) as exc:
        print(f"detection_bound: {exc}", file=sys.stderr)
        return 2
    print(
        f"oracle detection delay after {DETECTION_RECEIVERS} aircraft heard the spoofer, "
        f"false alarm {args.false_alarm:g}, detection {args.detection:g} (lambda {needed:.1f}), "
        f"{len(curves)} runs: median / p90 / worst (s)"
    )
    for exponent in (float(x) for x in args.exponents.split(",")):
        for sigma in (float(x) for x in args.sigmas.split(",")):
            delays = [detection_bound_s(c, exponent, sigma, needed) for c in curves]
            print(f"  exponent {exponent:g}, sigma {sigma:g} dB: {delay_summary(delays)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
