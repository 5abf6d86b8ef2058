"""``ridsafe run``'s own output: what a user sees before the flight starts."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from ridsafe.tools.cli import entry_point as cli_main
from ridsafe.tools.cli import run_cmd


def test_a_lockstep_run_says_it_loads_the_kernels_before_its_bar(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """On a fresh install the kernels compile for about a minute before the first tick: the
    run says so when it starts building, and how long it took once it flies."""
    argv = ["run", "--mode", "lockstep", "--one-process", "--duration", "1"]
    assert cli_main.main([*argv, "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err
    ready = re.search(re.escape(run_cmd.KERNELS_NOTICE) + r"ready in \d+\.\d s\n", err)
    assert ready is not None, err
    assert "sim time" in err[ready.end() :]


def test_a_run_stopped_before_its_first_tick_ends_the_notice_line(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Ctrl-C while the kernels compile: the notice's line is ended, not left open for the
    next message."""
    bar = run_cmd._SimTimeBar(10.0, announce=True)
    bar.close()
    assert capsys.readouterr().err == run_cmd.KERNELS_NOTICE + "stopped\n"
