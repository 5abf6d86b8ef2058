"""The ``ridsafe`` command line: one console script, one module per subcommand.

Each subcommand module (``ridsafe.tools.cli.<name>_cmd``) exposes ``register(subparsers) ->
None``, which adds its parser and sets ``func`` (``Callable[[argparse.Namespace], int]``) as the
parser default. Subcommand modules are imported only when the parser is built, and only the
named one when the command line names one.
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
import importlib.metadata  # noqa: E402
import logging  # noqa: E402
import sys  # noqa: E402
from collections.abc import Sequence  # noqa: E402

# Subcommand names and their modules, in the order ``ridsafe --help`` lists them.
_SUBCOMMAND_MODULES: dict[str, str] = {
    "run": "ridsafe.tools.cli.run_cmd",
    "sweep": "ridsafe.tools.cli.sweep_cmd",
    "report": "ridsafe.tools.cli.report_cmd",
    "sim": "ridsafe.tools.cli.sim_cmd",
    "gcs": "ridsafe.tools.cli.gcs_cmd",
    "companion": "ridsafe.tools.cli.companion_cmd",
    "metrics": "ridsafe.tools.cli.metrics_cmd",
    "odid": "ridsafe.tools.cli.odid_cmd",
    "demo": "ridsafe.tools.cli.demo_cmd",
}


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The ``ridsafe`` parser with every subcommand; given a subcommand's name, with that one
    alone, whose module alone is then imported (a live run's companion process need not
    import the GCS, the sweep and the report: about a second each process)."""
    parser = argparse.ArgumentParser(
        prog="ridsafe",
        description="Spoofing-aware Remote ID trajectory planning for small drones.",
    )
    parser.add_argument(
        "-v", "--verbose", action="count", default=0, help="more log output (-vv for debug)"
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    names = [command] if command in _SUBCOMMAND_MODULES else list(_SUBCOMMAND_MODULES)
    for name in names:
        importlib.import_module(_SUBCOMMAND_MODULES[name]).register(subparsers)
    return parser


def _version() -> str:
    """The installed distribution's version (a source tree run without installing: unknown)."""
    try:
        return importlib.metadata.version("ridsafe")
    except importlib.metadata.PackageNotFoundError:
        return "(not installed)"


def _command_of(argv: Sequence[str]) -> str | None:
    """The subcommand ``argv`` names (its first word that is not an option; the only global
    option, ``-v``, takes no value), or None where it asks for the global help or the
    version first."""
    for arg in argv:
        if arg in ("-h", "--help", "--version"):
            return None
        if not arg.startswith("-"):
            return arg
    return None


EXIT_INTERRUPTED = 130  # 128 + SIGINT, as shells report a Ctrl-C
EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE, as a shell reports a writer whose reader left


def main(argv: Sequence[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    parser = build_parser(_command_of(argv))
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
