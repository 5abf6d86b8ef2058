"""The ``ridsafe`` command line: one console script, one module per subcommand.

Each subcommand module (``ridsafe.tools.cli.<name>_cmd``) exposes ``register(subparsers) ->
None``, which adds its parser and sets ``func`` (``Callable[[argparse.Namespace], int]``) as the
parser default. Subcommand modules are imported only when the parser is built.
"""

from __future__ import annotations

import os

# Every ridsafe process is one single-threaded loop (a live run is several processes, a sweep
# a pool of them): BLAS worker threads only contend for the cores and stall the GCS cycle.
# Set before numpy is first imported (the subcommand modules import it).
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import importlib  # noqa: E402
import logging  # noqa: E402
import sys  # noqa: E402
from collections.abc import Sequence  # noqa: E402

# Subcommand modules, in the order ``ridsafe --help`` lists them.
_SUBCOMMAND_MODULES: tuple[str, ...] = (
    "ridsafe.tools.cli.run_cmd",
    "ridsafe.tools.cli.sweep_cmd",
    "ridsafe.tools.cli.report_cmd",
    "ridsafe.tools.cli.sim_cmd",
    "ridsafe.tools.cli.gcs_cmd",
    "ridsafe.tools.cli.companion_cmd",
    "ridsafe.tools.cli.metrics_cmd",
    "ridsafe.tools.cli.odid_cmd",
    "ridsafe.tools.cli.demo_cmd",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="ridsafe",
        description="Spoofing-aware Remote ID trajectory planning for small drones.",
    )
    parser.add_argument(
        "-v", "--verbose", action="count", default=0, help="more log output (-vv for debug)"
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for module_name in _SUBCOMMAND_MODULES:
        importlib.import_module(module_name).register(subparsers)
    return parser


EXIT_INTERRUPTED = 130  # 128 + SIGINT, as shells report a Ctrl-C
EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE, as a shell reports a writer whose reader left


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    level = {0: logging.WARNING, 1: logging.INFO}.get(args.verbose, logging.DEBUG)
    logging.basicConfig(level=level, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    if not hasattr(args, "func"):
        parser.print_help()
        return 2
    try:
        result: int = args.func(args)
    except KeyboardInterrupt:  # before a command's own Ctrl-C handling began (or after it)
        print(f"ridsafe {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # `ridsafe odid capture FILE | head`: the reader has gone
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # so the exit's flush does not fail again
        return EXIT_BROKEN_PIPE
    return result
