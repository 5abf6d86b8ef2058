"""No compiled kernel uses ``fastmath`` (``common/jit.py`` says why: with it, a run's last
bits depended on what numba's on-disk cache held before it)."""

from __future__ import annotations

import importlib
from pathlib import Path

from numba.core.dispatcher import Dispatcher

ROOT = Path(__file__).resolve().parents[2]


def _kernel_modules() -> list[str]:
    """Every module of ``ridsafe`` that compiles a kernel with ``common/jit.py``."""
    names = []
    for path in sorted((ROOT / "ridsafe").rglob("*.py")):
        if "from ridsafe.common.jit import" in path.read_text(encoding="utf-8"):
            names.append(".".join(path.relative_to(ROOT).with_suffix("").parts))
    return names


def test_no_kernel_is_compiled_with_fastmath() -> None:
    kernels = {}
    for name in _kernel_modules():
        module = importlib.import_module(name)
        for attr, value in vars(module).items():
            if isinstance(value, Dispatcher) and value.__module__ == name:
                kernels[f"{name}.{attr}"] = value.targetoptions
    assert len(kernels) > 40, sorted(kernels)  # every kernel module was found and read
    assert not [k for k, options in kernels.items() if options.get("fastmath")]


def test_nothing_in_the_package_asks_numba_for_fastmath() -> None:
    """Nor a kernel compiled some other way than ``common/jit.py``'s decorators."""
    asking = [
        str(path.relative_to(ROOT))
        for path in sorted((ROOT / "ridsafe").rglob("*.py"))
        if "fastmath" in path.read_text(encoding="utf-8").replace("``fastmath``", "")
    ]
    assert asking == []
