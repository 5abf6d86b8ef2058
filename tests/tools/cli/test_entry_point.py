"""The ``ridsafe`` command line itself: every subcommand registered in order, help without a
command, and the two ways in (console script entry point, ``python -m``)."""

from __future__ import annotations

import subprocess
import sys
from importlib.metadata import entry_points
from pathlib import Path

import pytest

from ridsafe.tools.cli import entry_point as cli_main

ROOT = Path(__file__).resolve().parents[3]
SUBCOMMANDS = ["run", "sweep", "report", "sim", "gcs", "companion", "metrics", "odid", "demo"]


def test_every_subcommand_is_registered_in_order() -> None:
    parser = cli_main.build_parser()
    (subparsers,) = [a for a in parser._actions if a.dest == "command"]
    assert list(subparsers.choices) == SUBCOMMANDS  # type: ignore[arg-type]


def test_no_command_prints_help_and_exits_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main.main([]) == 2
    assert "usage: ridsafe" in capsys.readouterr().out


def test_the_console_script_points_at_main() -> None:
    (script,) = [e for e in entry_points(group="console_scripts") if e.name == "ridsafe"]
    assert script.load() is cli_main.main


def test_python_dash_m_runs_the_same_command() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "ridsafe.tools.cli", "--help"],
        cwd=ROOT, capture_output=True, text=True, check=False, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert all(name in done.stdout for name in SUBCOMMANDS)
