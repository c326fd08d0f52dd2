"""The package's layering, read from the source: the import graph and where Numba flags live.

Imports anywhere in a module count, lazy ones inside functions included: a lazy import
still ties the two modules together. A package's ``__init__`` only re-exports its
modules, so an import of a package counts as an import of the modules it re-exports.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = SRC / "motes"

#: Packages and modules below the renderer: physics, state, geometry, spatial, io.
BELOW_RENDER = (
    "motes.geometry", "motes.spatial", "motes.state", "motes.particles", "motes.emit",
    "motes.forces", "motes.integrate", "motes.collide", "motes.constrain", "motes.rigid",
    "motes.cloth", "motes.hair", "motes.fluids", "motes.life", "motes.couple",
    "motes.system", "motes.hierarchy", "motes.io",
)  # fmt: skip
ABOVE = ("motes.render", "motes.scene", "motes.cli")


def _module_name(path: Path) -> str:
    parts = path.relative_to(SRC).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in PACKAGE.rglob("*.py")}


def _imports(name: str, path: Path, modules) -> set[str]:
    """Modules of motes that ``name`` imports (packages expanded to what they export)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.startswith("motes"))
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if not target.startswith("motes"):
                continue
            for alias in node.names:
                sub = f"{target}.{alias.name}"
                found.add(sub if sub in modules else target)
    return {m for m in found if m in modules and m != name}


def _graph():
    modules = _modules()
    return {name: _imports(name, path, modules) for name, path in modules.items()}, modules


def _expanded(graph, modules):
    """Edges through packages' ``__init__`` replaced by edges to what they re-export."""
    packages = {m for m, p in modules.items() if p.name == "__init__.py"}

    def targets(m, seen):
        if m not in packages:
            return {m}
        out = set()
        for t in graph[m]:
            if t not in seen:
                out |= targets(t, seen | {t})
        return out

    return {
        m: set().union(*(targets(t, {t}) for t in edges)) - {m} if edges else set()
        for m, edges in graph.items()
        if m not in packages
    }


def _cycles(graph) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on_stack, result = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                result.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return result


def test_no_two_modules_import_each_other():
    graph, modules = _graph()
    assert _cycles(_expanded(graph, modules)) == []


def _within(name: str, prefixes) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def test_physics_state_geometry_and_io_never_import_the_renderer_scenes_or_the_cli():
    graph, modules = _graph()
    expanded = _expanded(graph, modules)
    wrong = {
        m: sorted(t for t in targets if _within(t, ABOVE))
        for m, targets in expanded.items()
        if _within(m, BELOW_RENDER)
    }
    assert {m: t for m, t in wrong.items() if t} == {}


def test_geometry_imports_nothing_above_the_jit_helpers():
    graph, modules = _graph()
    allowed = ("motes.geometry", "motes._jit", "motes._validate", "motes._tracked")
    for m, targets in _expanded(graph, modules).items():
        if _within(m, ("motes.geometry",)):
            assert all(_within(t, allowed) for t in targets), (m, targets)


@pytest.mark.parametrize("flag", ["fastmath", "parallel", "cache", "error_model", "nogil"])
def test_numba_flags_are_set_only_in_the_jit_module(flag):
    """Every kernel takes its flags from ``motes._jit`` (one place to change them)."""
    offenders = []
    for path in PACKAGE.rglob("*.py"):
        if path.name == "_jit.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and any(k.arg == flag for k in node.keywords):
                offenders.append(f"{path.relative_to(SRC)}:{node.lineno}")
    assert offenders == []


def test_kernel_files_follow_one_naming_convention():
    """``kernels.py`` or ``TOPIC_kernels.py``, never a private ``_kernels.py``."""
    names = sorted(str(p.relative_to(SRC)) for p in PACKAGE.rglob("*kernels*.py"))
    assert names, "no kernel files found"
    odd = [n for n in names if not re.fullmatch(r"([a-z]+_)?kernels\.py", Path(n).name)]
    assert odd == []


def test_the_checks_see_a_known_edge():
    """Guard against a parser that finds nothing (every test above would then pass)."""
    graph, modules = _graph()
    assert "motes.particles" in _expanded(graph, modules)["motes.system"]
    assert len(modules) > 80
