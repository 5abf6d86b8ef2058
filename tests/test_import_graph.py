"""The import graph of ``ridsafe`` read from the source (``ast``, nothing imported): no cycles,
and the layering rules hold (apps never import each other, ``common`` imports no app, nothing
under ``ridsafe/`` or ``bench/`` imports ``tests``).

Every ``import`` counts, also one inside a function (a lazy import is still a dependency),
except under ``if TYPE_CHECKING:``. Importing ``a.b.c`` also depends on the packages ``a`` and
``a.b`` (their ``__init__`` runs first).
"""

from __future__ import annotations

import ast
import functools
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
APPS = ("ridsafe.companion", "ridsafe.gcs", "ridsafe.sim_backend")


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _import_nodes(tree: ast.AST) -> Iterator[ast.Import | ast.ImportFrom]:
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, ast.If) and _is_type_checking(node):
            continue
        if isinstance(node, ast.Import | ast.ImportFrom):
            yield node
        yield from _import_nodes(node)


@functools.cache
def _tree(path: Path) -> ast.Module:
    """The parsed source of ``path``, once per test session (the generated dialect alone takes
    a good part of a second)."""
    return ast.parse(path.read_text(encoding="utf-8"))


def imported(path: Path, known: set[str]) -> set[str]:
    """The project modules ``path`` imports (with their parent packages)."""
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    targets: set[str] = set()
    for node in _import_nodes(_tree(path)):
        if isinstance(node, ast.Import):
            targets.update(alias.name for alias in node.names)
            continue
        base = node.module or ""
        if node.level:
            anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
            base = ".".join([*anchor, base] if base else anchor)
        targets.add(base)
        targets.update(f"{base}.{alias.name}" for alias in node.names)  # submodules
    found: set[str] = set()
    for target in targets:
        parts = target.split(".")
        found.update(p for k in range(1, len(parts) + 1) if (p := ".".join(parts[:k])) in known)
    found.discard(name)
    # Python loads a module's own packages before the module; a submodule naming its package's
    # sibling (``pkg.a`` imports ``pkg.b``) does not make it depend on ``pkg/__init__``.
    parts = name.split(".")
    found.difference_update(".".join(parts[:k]) for k in range(1, len(parts)))
    return found


@functools.cache
def graph(*folders: str) -> dict[str, set[str]]:  # read only: shared by the tests
    paths = [p for folder in folders for p in sorted((ROOT / folder).rglob("*.py"))]
    known = {module_name(p) for p in paths}
    return {module_name(p): imported(p, known) for p in paths}


def find_cycle(edges: dict[str, set[str]]) -> list[str] | None:
    """One cycle of the graph as a list of modules (first == last), or None."""
    state: dict[str, int] = {}  # 1: on the stack, 2: done
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(edges.get(node, ())):
            if state.get(nxt) == 1:
                return [*stack[stack.index(nxt) :], nxt]
            if nxt not in state and (cycle := visit(nxt)) is not None:
                return cycle
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(edges):
        if node not in state and (cycle := visit(node)) is not None:
            return cycle
    return None


def test_the_cycle_finder_finds_a_cycle() -> None:
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set(), "c": {"a", "b"}}) is None


def test_every_package_folder_is_a_package() -> None:
    """A folder of modules without ``__init__.py`` is left out of an installed wheel."""
    for folder in sorted({p.parent for p in (ROOT / "ridsafe").rglob("*.py")}):
        assert (folder / "__init__.py").exists(), folder


def test_imports_resolve_to_modules_and_their_packages() -> None:
    edges = graph("ridsafe")
    assert "ridsafe.tools.run.cores" in edges["ridsafe.tools.run.lockstep"]
    assert "ridsafe.common" in edges["ridsafe.tools.run.lockstep"]  # another package runs first
    assert "ridsafe.tools.run" not in edges["ridsafe.tools.run.lockstep"]  # its own: by Python
    assert "ridsafe.tools.cli.entry_point" in edges["ridsafe.tools.cli"]


def test_ridsafe_has_no_import_cycle() -> None:
    assert find_cycle(graph("ridsafe")) is None


@pytest.mark.parametrize("app", APPS)
def test_apps_never_import_each_other(app: str) -> None:
    others = [a for a in APPS if a != app]
    for module, targets in graph("ridsafe").items():
        if module == app or module.startswith(app + "."):
            bad = sorted(t for t in targets for o in others if t == o or t.startswith(o + "."))
            assert not bad, f"{module} imports {bad}"


def test_common_imports_no_app_and_nothing_imports_tools_but_tools() -> None:
    for module, targets in graph("ridsafe").items():
        if module.startswith("ridsafe.common"):
            assert not [t for t in targets if t.startswith(APPS)], module
        # ``python -m ridsafe`` is the command line, which lives in tools; nothing imports it.
        if not module.startswith("ridsafe.tools") and module != "ridsafe.__main__":
            assert not [t for t in targets if t.startswith("ridsafe.tools")], module


def test_nothing_in_ridsafe_or_bench_imports_tests() -> None:
    for folder in ("ridsafe", "bench"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            for node in _import_nodes(_tree(path)):
                names = (
                    [a.name for a in node.names]
                    if isinstance(node, ast.Import)
                    else [node.module or ""]
                )
                assert not [n for n in names if n == "tests" or n.startswith("tests.")], path


#: The layout's limit on a module's length (docs/architecture.md), the generated dialect aside.
MAX_MODULE_LINES = 600
GENERATED = Path("ridsafe/common/dialect/ridsafe_v20.py")


def test_no_module_is_over_600_lines_but_the_generated_dialect() -> None:
    lines = {
        path.relative_to(ROOT): len(path.read_text(encoding="utf-8").splitlines())
        for path in sorted((ROOT / "ridsafe").rglob("*.py"))
    }
    long = {path for path, n in lines.items() if n > MAX_MODULE_LINES and path != GENERATED}
    assert not long, {str(p): lines[p] for p in long}
