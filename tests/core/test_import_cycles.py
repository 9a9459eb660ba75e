"""No import cycle among the modules of ``core``.

Every ``import`` and ``from ... import`` in ``core/**/*.py`` counts, at module level and inside functions (an
import inside a function only hides a cycle, it does not break it); ``if TYPE_CHECKING:`` blocks count too.
A ``from package import name`` counts as an import of ``package.name`` when that is a module, else of the
package. The graph of these edges must be acyclic.
"""

from __future__ import annotations

import ast
from pathlib import Path

CORE = Path(__file__).resolve().parents[2] / "core"


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(CORE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(["rigidlab", *parts])


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in sorted(CORE.rglob("*.py"))}


def _resolve(module: str, path: Path, level: int, target: str | None) -> str:
    """Absolute name of a (relative) import target in ``module`` (a package's __init__ is the package)."""
    if level == 0:
        return target or ""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for _ in range(level - 1):
        package = package.rpartition(".")[0]
    return f"{package}.{target}" if target else package


def import_graph() -> dict[str, set[str]]:
    """``module -> modules of core it imports`` (a package import also runs the package's ``__init__``)."""
    modules = _modules()
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for module, path in modules.items():
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = _resolve(module, path, node.level, node.module)
                targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base
                           for alias in node.names]
            for name in targets:
                # importing a.b.c runs a, a.b and a.b.c
                parts = name.split(".")
                for k in range(1, len(parts) + 1):
                    prefix = ".".join(parts[:k])
                    if prefix in modules and prefix != module and not module.startswith(prefix + "."):
                        graph[module].add(prefix)
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of ``graph`` as a list of modules (first == last), or None (iterative depth-first search)."""
    colour = dict.fromkeys(graph, 0)  # 0 new, 1 on the stack, 2 done
    for root in sorted(graph):
        if colour[root]:
            continue
        stack = [(root, iter(sorted(graph[root])))]
        colour[root] = 1
        while stack:
            node, children = stack[-1]
            for child in children:
                if colour[child] == 1:
                    path = [n for n, _ in stack]
                    return path[path.index(child):] + [child]
                if colour[child] == 0:
                    colour[child] = 1
                    stack.append((child, iter(sorted(graph[child]))))
                    break
            else:
                colour[node] = 2
                stack.pop()
    return None


def test_the_checker_finds_a_cycle_and_accepts_a_tree():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b", "c"}, "b": {"c"}, "c": set()}) is None


def test_the_graph_sees_imports_inside_functions_and_relative_imports():
    graph = import_graph()
    # core/multibody/_evaluation.py: `from ._simulate import _Dynamics` inside evaluate()
    assert "rigidlab.core.multibody._simulate" in graph["rigidlab.core.multibody._evaluation"]
    # core/contact/_kernel.py: `from . import _compiled, _scalar`
    assert {"rigidlab.core.contact._compiled", "rigidlab.core.contact._scalar"} <= graph["rigidlab.core.contact._kernel"]
    # an absolute import of a package runs its __init__
    assert "rigidlab.core.contact" in graph["rigidlab.core.models._cam"]


def test_core_has_no_import_cycle():
    cycle = find_cycle(import_graph())
    assert cycle is None, "import cycle in core: " + " -> ".join(cycle)
