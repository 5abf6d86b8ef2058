"""Every command-line value (numbers, connection strings, lists) is checked where it is parsed,
and its error names the flag; a bad ``--set`` names its key."""

from __future__ import annotations

import pytest

from ridsafe.tools.cli import entry_point as cli_main


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["run", "--duration", "-5"], "argument --duration: must be > 0, got -5"),
        (["run", "--duration", "nan"], "argument --duration: must be finite, got nan"),
        (["run", "--seed", "-1"], "argument --seed: must be >= 0, got -1"),
        (["run", "--aircraft", "0"], "argument --aircraft: must be >= 1, got 0"),
        (["run", "--speed", "fast"], "argument --speed: expected a number, got 'fast'"),
        (["sim", "--speed", "0"], "argument --speed: must be > 0, got 0"),
        (["sim", "--duration", "-1"], "argument --duration: must be > 0, got -1"),
        (["sim", "--vehicles", "-2"], "argument --vehicles: must be >= 1, got -2"),
        (["gcs", "--speed", "0"], "argument --speed: must be > 0, got 0"),
        (["companion", "--duration", "0"], "argument --duration: must be > 0, got 0"),
        (["gcs", "--t0-unix", "inf"], "argument --t0-unix: must be finite, got inf"),
        (["sweep", "--workers", "0"], "argument --workers: must be >= 1, got 0"),
        (["demo", "--speed", "-4"], "argument --speed: must be > 0, got -4"),
        (["gcs", "--listen", "nope"], "argument --listen: connection string 'nope'"),
        (["gcs", "--listen", "udpout:127.0.0.1:5"], "argument --listen: GCS listen address"),
        (["companion", "--vehicle", "1", "--gcs", "x"], "argument --gcs: connection string"),
        (["companion", "--vehicle", "1", "--autopilot", "a:1"], "argument --autopilot: conn"),
        (["companion", "--vehicle", "1", "--rid-start-s", "nan"], "--rid-start-s: must be fin"),
        (["sweep", "x.yaml", "--densities", "4,a"], "argument --densities: expected an integer"),
        (["sweep", "x.yaml", "--densities", "0"], "argument --densities: must be >= 1, got 0"),
        (["sweep", "x.yaml", "--seeds", "5:1"], "argument --seeds: expected distinct non-neg"),
    ],
)
def test_a_bad_number_is_refused_naming_its_flag(
    argv: list[str], expected: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_info:
        cli_main.main(argv)
    assert exit_info.value.code == 2
    assert expected in capsys.readouterr().err


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["run", "--set", "scenario.duration_s=-1"], "override: scenario.duration_s: expected 0 <"),
        (["run", "--set", "scenario.nope=1"], "override: scenario.nope: unknown key"),
        (["companion", "--vehicle", "0"], "--vehicle '0': no benign aircraft"),
        (["run", "--set", "run.gcs_connect=udpin:127.0.0.1:5"], "run.gcs_connect: expected udpout"),
        (["run", "--set", "run.gcs_listen=nope"], "run.gcs_listen: connection string 'nope'"),
        (["run", "--one-process"], "--one-process: only with --mode lockstep"),
    ],
)
def test_a_bad_value_after_parsing_names_its_key_or_flag(
    argv: list[str], expected: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert cli_main.main(argv) == 2
    assert expected in capsys.readouterr().err
