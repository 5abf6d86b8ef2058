"""The ``ridsafe`` command line itself: every subcommand registered in order, help without a
command, and the two ways in (console script entry point, ``python -m``)."""

from __future__ import annotations

import subprocess
import sys
from importlib.metadata import entry_points, version
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


@pytest.mark.parametrize("module", ["ridsafe", "ridsafe.tools.cli"])
def test_python_dash_m_runs_the_same_command(module: str) -> None:
    done = subprocess.run(
        [sys.executable, "-m", module, "--help"],
        cwd=ROOT, capture_output=True, text=True, check=False, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert all(name in done.stdout for name in SUBCOMMANDS)


def test_version_is_the_installed_distributions(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as done:
        cli_main.main(["--version"])
    assert done.value.code == 0
    assert capsys.readouterr().out.strip() == f"ridsafe {version('ridsafe')}"


def test_a_named_command_registers_that_command_alone() -> None:
    parser = cli_main.build_parser("odid")
    (subparsers,) = [a for a in parser._actions if a.dest == "command"]
    assert list(subparsers.choices) == ["odid"]  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("argv", "command"),
    [
        (["run", "--help"], "run"),
        (["-v", "-v", "companion", "--sysid", "3"], "companion"),
        (["-h", "run"], None),  # the global help first
        (["-v"], None),
        ([], None),
    ],
)
def test_the_command_a_command_line_names(argv: list[str], command: str | None) -> None:
    assert cli_main._command_of(argv) == command


def test_a_companion_process_imports_neither_the_gcs_nor_the_other_commands() -> None:
    """What a live run's per-aircraft process loads before it flies (each of them)."""
    probe = (
        "import sys\n"
        "from ridsafe.tools.cli.entry_point import main\n"
        "try:\n"
        "    main(['companion', '--help'])\n"
        "except SystemExit:\n"
        "    pass\n"
        "heavy = ('ridsafe.gcs.gcs', 'ridsafe.gcs.calibration.pipeline', 'scipy.stats',\n"
        "    'ridsafe.tools.cli.run_cmd', 'ridsafe.tools.cli.sweep_cmd')\n"
        "loaded = [m for m in heavy if m in sys.modules]\n"
        "print(loaded, file=sys.stderr)\n"
        "sys.exit(1 if loaded else 0)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe],
        cwd=ROOT, capture_output=True, text=True, check=False, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "usage: ridsafe companion" in done.stdout
