"""Every command-line number is checked where it is parsed, and its error names the flag."""

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
    ],
)
def test_a_bad_number_is_refused_naming_its_flag(
    argv: list[str], expected: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_info:
        cli_main.main(argv)
    assert exit_info.value.code == 2
    assert expected in capsys.readouterr().err
