"""``ridsafe report``: the paper's tables (Markdown and CSV) and plots from sweep folders.

    ridsafe report out/sweep-paper                        # our defaults vs the paper
    ridsafe report out/sweep-paper out/sweep-paper_mode   # both side by side vs the paper

Per density and planner: NMACs (total, benign-benign, benign-spoofer), unsafe violations,
containment rate, RMSE, MAE, max ellipsoid radius, wall clock and GCS compute per run (mean
+/- std), each beside the paper's published value (Tables 2 and 3) and the difference; also
goal-reached fraction, detection time and false alerts, which the paper does not report.
Plots: the paper's Fig. 3 (16 aircraft) per sweep and NMACs against density. Numbers come
from the run logs (result.json caches them; --recompute reads every log again; metrics read
from logs are computed on --workers processes, with a progress bar, and cached again).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import NoReturn

from tqdm import tqdm

from ridsafe.common.errors import RidsafeError
from ridsafe.tools.analysis.report import write_report
from ridsafe.tools.cli.arg_types import positive_int
from ridsafe.tools.sweep.engines import default_workers


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "report",
        help="tables (Markdown, CSV) and plots of sweeps, beside the paper's published values",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("dirs", nargs="+", type=Path, metavar="DIR", help="sweep folder(s)")
    parser.add_argument("--out", type=Path, help="report folder (default: first DIR/report)")
    parser.add_argument(
        "--recompute", action="store_true", help="compute every run's metrics from its log"
    )
    parser.add_argument(
        "--no-plots",
        action="store_true",
        help="tables only, from the cached metrics (no log read for plots or the detectors' ROC)",
    )
    parser.add_argument(
        "--fig3-density", type=int, default=16, help="aircraft of the Fig. 3 runs (default 16)"
    )
    parser.add_argument(
        "--workers",
        type=positive_int,
        default=default_workers(),
        help="processes that compute metrics from logs (default: every core)",
    )
    parser.set_defaults(func=run)


class _MetricsBar:
    """A progress bar over the runs whose metrics come from their logs (none when every
    cache is fresh)."""

    def __init__(self) -> None:
        self.bar: tqdm[NoReturn] | None = None

    def __call__(self, done: int, total: int) -> None:
        if self.bar is None:
            self.bar = tqdm(total=total, desc="metrics from logs", unit="run", leave=False)
        self.bar.update(done - self.bar.n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def run(args: argparse.Namespace) -> int:
    out: Path = args.out or args.dirs[0] / "report"
    bar = _MetricsBar()
    try:
        files = write_report(
            args.dirs,
            out,
            recompute=args.recompute,
            with_plots=not args.no_plots,
            fig3_density=args.fig3_density,
            workers=args.workers,
            progress=bar,
        )
    except (RidsafeError, OSError, ValueError) as exc:
        print(f"ridsafe report: {exc}", file=sys.stderr)
        return 2
    finally:
        bar.close()
    print(f"report: {files.markdown}")
    print(f"table:  {files.csv}")
    for path in files.plots:
        print(f"plot:   {path}")
    return 0
