"""Check that batecho's modules import each other without a circle.

Parses every ``.py`` file of the package with :mod:`ast` (nothing is imported or run) and
builds the graph of imports between its modules: every ``import`` and ``from ... import``
statement counts, at module level, inside functions and under ``if TYPE_CHECKING:`` alike.
``from package import name`` counts as an import of the module ``package.name`` when there is
one, else of ``package``; importing a module does not count as importing its parent package.

Two graphs must be free of cycles:

* the modules (``batecho.forest.ipp`` -> ``batecho.trees.leaves``);
* the subpackages and top-level modules (``forest`` -> ``trees``), leaving out the package's
  own ``__init__`` (the public facade, which imports from all of them).

And the subpackages follow the data in :data:`LAYERS`: each imports only from earlier layers,
never from a sibling of its own layer, and every subpackage or top-level module has a layer.

Usage::

    python tools/import_graph.py            # check; exit status 1 and the cycles if any
    python tools/import_graph.py --order    # also print the subpackages in import order
"""

from __future__ import annotations

import argparse
import ast
import sys
from collections.abc import Iterable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE_DIR = ROOT / "python" / "batecho"

#: batecho's subpackages and top-level modules in import order: trees -> forest -> flight ->
#: sonar -> echoes -> outputs -> scene files, paper, datasets -> command line.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("_core", "_validate", "_geometry", "_random", "_pickle", "_equal"),
    ("_resources",),
    ("trees",),
    ("forest",),
    ("flight",),
    ("sonar",),
    ("echoes",),
    ("reference", "outputs"),
    ("scenefile", "paper", "dataset", "plotting", "treeplots", "trajectories", "envs"),
    ("cli",),
    ("__main__",),
)


def module_names(package_dir: Path) -> dict[str, Path]:
    """Dotted module name -> file, for every ``.py`` file under ``package_dir`` and every
    ``.pyi`` stub without one (an extension module such as ``batecho._core``)."""
    base = package_dir.parent
    out: dict[str, Path] = {}
    for path in sorted(package_dir.rglob("*.py*")):
        if path.suffix not in (".py", ".pyi"):
            continue
        parts = list(path.relative_to(base).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        name = ".".join(parts)
        if path.suffix == ".py" or name not in out:
            out[name] = path
    return out


def _resolve(current: str, is_package: bool, level: int, module: str | None) -> str:
    """The absolute name of a (possibly relative) ``from`` import's module."""
    if level == 0:
        return module or ""
    parts = current.split(".")
    if not is_package:
        parts = parts[:-1]
    if level > 1:
        parts = parts[: len(parts) - (level - 1)]
    if module:
        parts.append(module)
    return ".".join(parts)


def imports_of(name: str, path: Path, modules: Iterable[str]) -> set[str]:
    """The package's modules that module ``name`` (file ``path``) imports."""
    known = set(modules)
    if path.suffix == ".pyi":
        return set()
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    is_package = path.name == "__init__.py"
    found: set[str] = set()

    def add(target: str) -> None:
        # the longest known module that the dotted name starts with
        parts = target.split(".")
        while parts:
            candidate = ".".join(parts)
            if candidate in known:
                found.add(candidate)
                return
            parts.pop()

    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                add(alias.name)
        elif isinstance(node, ast.ImportFrom):
            base = _resolve(name, is_package, node.level, node.module)
            for alias in node.names:
                full = f"{base}.{alias.name}" if base else alias.name
                add(full if full in known else base)
    found.discard(name)
    return found


def build_graph(package_dir: Path = PACKAGE_DIR) -> dict[str, set[str]]:
    """Module -> the package's modules it imports."""
    modules = module_names(package_dir)
    return {m: imports_of(m, p, modules) for m, p in modules.items()}


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's algorithm (iterative): the components with more than one node, sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    out: list[list[str]] = []
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            advanced = False
            for child in children:
                if child not in graph:
                    continue
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                    advanced = True
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            if advanced:
                continue
            work.pop()
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[node])
            if low[node] == index[node]:
                comp = []
                while True:
                    top = stack.pop()
                    on_stack.discard(top)
                    comp.append(top)
                    if top == node:
                        break
                if len(comp) > 1:
                    out.append(sorted(comp))
    return sorted(out)


def package_graph(graph: dict[str, set[str]], root: str = "batecho") -> dict[str, set[str]]:
    """The graph between the root package's direct children (subpackages and modules),
    without the root's ``__init__``."""

    def top(module: str) -> str | None:
        parts = module.split(".")
        return parts[1] if len(parts) > 1 and parts[0] == root else None

    out: dict[str, set[str]] = {}
    for mod, deps in graph.items():
        a = top(mod)
        if a is None:
            continue
        out.setdefault(a, set())
        for d in deps:
            b = top(d)
            if b is not None and b != a:
                out[a].add(b)
    return out


def import_order(graph: dict[str, set[str]]) -> list[str]:
    """A topological order (each node after everything it imports), ties broken by name;
    the nodes of a cycle come last."""
    order: list[str] = []
    pending = {n: {d for d in deps if d in graph} for n, deps in graph.items()}
    while pending:
        ready = sorted(n for n, deps in pending.items() if not deps - set(order))
        if not ready:
            return order + sorted(pending)
        order += ready
        for n in ready:
            del pending[n]
    return order


def cycle_path(graph: dict[str, set[str]], comp: list[str]) -> list[str]:
    """One closed path through a strongly connected component, for the message."""
    members = set(comp)
    start = comp[0]
    path = [start]
    seen = {start}
    node = start
    while True:
        nxt = sorted(d for d in graph[node] if d in members)
        back = [d for d in nxt if d == start]
        if back and len(path) > 1:
            return [*path, start]
        fresh = [d for d in nxt if d not in seen]
        if not fresh:
            return [*path, nxt[0]] if nxt else path
        node = fresh[0]
        seen.add(node)
        path.append(node)


def layer_problems(pkg: dict[str, set[str]], layers: tuple[tuple[str, ...], ...]) -> list[str]:
    """Imports against the layer order, and subpackages without a layer."""
    rank = {name: i for i, layer in enumerate(layers) for name in layer}
    problems = []
    for name in sorted(pkg):
        if name not in rank:
            problems.append(f"layer: {name} is in no layer of tools/import_graph.py LAYERS")
            continue
        for dep in sorted(pkg[name]):
            if dep in rank and rank[dep] >= rank[name]:
                where = "its own layer" if rank[dep] == rank[name] else "a later layer"
                problems.append(f"layer: {name} imports {dep}, from {where}")
    return problems


def check(
    package_dir: Path = PACKAGE_DIR, layers: tuple[tuple[str, ...], ...] | None = LAYERS
) -> list[str]:
    """Problems found (empty when both graphs are acyclic and, unless ``layers`` is None, the
    subpackages keep to their layers)."""
    graph = build_graph(package_dir)
    problems = []
    for comp in strongly_connected(graph):
        problems.append("module cycle: " + " -> ".join(cycle_path(graph, comp)))
    pkg = package_graph(graph)
    for comp in strongly_connected(pkg):
        problems.append("subpackage cycle: " + " -> ".join(cycle_path(pkg, comp)))
    if layers is not None:
        problems += layer_problems(pkg, layers)
    return problems


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--package", type=Path, default=PACKAGE_DIR, help="package folder")
    ap.add_argument("--order", action="store_true", help="print the subpackage import order")
    args = ap.parse_args(argv)
    problems = check(args.package)
    graph = build_graph(args.package)
    if args.order:
        pkg = package_graph(graph)
        for name in import_order(pkg):
            deps = ", ".join(sorted(pkg[name])) or "-"
            print(f"{name:<14} imports {deps}")
    for p in problems:
        print(p, file=sys.stderr)
    if problems:
        return 1
    print(f"no import cycle among {len(graph)} modules; the subpackages keep to their layers")
    return 0


if __name__ == "__main__":
    sys.exit(main())
