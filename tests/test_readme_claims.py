"""The README's reliability claims each name their test as ``file::test``: every name must
exist (a renamed or deleted test would leave a claim unbacked)."""

from __future__ import annotations

import re

from tests.tools.run.live_runs import ROOT

NAMED_TEST = re.compile(r"`(tests/[\w/]+\.py)::(test_\w+)`")


def test_every_test_the_readme_names_exists() -> None:
    named = NAMED_TEST.findall((ROOT / "README.md").read_text(encoding="utf-8"))
    assert len(named) >= 20
    missing = [
        f"{path}::{name}"
        for path, name in named
        if not re.search(rf"^def {name}\(", (ROOT / path).read_text(encoding="utf-8"), re.M)
    ]
    assert not missing, missing
