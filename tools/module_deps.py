#!/usr/bin/env python3
"""List the `crate::` dependencies between the top-level modules of the Rust core and fail on
a cycle.

A top-level module is a folder of `rust/src` (`math`, `physics`, ...) or a file beside
`lib.rs` (`simulate`, `error`), with the folder of its submodules if it has one
(`simulate.rs` and `simulate/`). An edge `a -> b` means some file under `a` names `crate::b`
in code (comments and string literals are ignored; `#[cfg(test)]` code counts too, so tests
keep to the same order). `lib.rs` itself (the module list and the unit tests' helpers) is
not a node.

Usage: python3 tools/module_deps.py [--quiet] [path/to/rust/src]
Exit status 0 when the graph has no cycle (the modules are printed in dependency order,
lowest first), 1 when it has one (the cycle is printed).
"""

from __future__ import annotations

import re
import sys
from collections import defaultdict
from pathlib import Path

COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)
CHAR = re.compile(r"'(?:\\.|[^'\\])'")
STRING = re.compile(r'r#*"(?:[\s\S]*?)"#*|"(?:\\[\s\S]|[^"\\])*"')
CRATE_PATH = re.compile(r"\bcrate::(\w+)")
# `use crate::{a::x, b::y}`: every first segment inside the braces
CRATE_GROUP = re.compile(r"\bcrate::\{([^}]*)\}")


def code_of(text: str) -> str:
    """The text without comments, character and string literals."""
    text = CHAR.sub("' '", text)
    text = STRING.sub('""', text)
    return COMMENT.sub("", text)


def top_modules(src: Path) -> dict[str, list[Path]]:
    """Top-level module name -> its source files."""
    mods: dict[str, list[Path]] = {}
    for p in sorted(src.iterdir()):
        if p.is_dir():
            mods.setdefault(p.name, []).extend(sorted(p.rglob("*.rs")))
        elif p.suffix == ".rs" and p.name != "lib.rs":
            # (a file beside a folder of the same name: the folder holds its submodules)
            mods.setdefault(p.stem, []).insert(0, p)
    return mods


def edges(src: Path) -> dict[str, dict[str, int]]:
    """a -> {b: number of references}, for a != b."""
    mods = top_modules(src)
    out: dict[str, dict[str, int]] = {m: defaultdict(int) for m in mods}
    for m, files in mods.items():
        for f in files:
            code = code_of(f.read_text())
            names = CRATE_PATH.findall(code)
            for group in CRATE_GROUP.findall(code):
                names += [g.strip().split("::")[0] for g in group.split(",") if g.strip()]
            for n in names:
                if n in mods and n != m:
                    out[m][n] += 1
    return out


def find_cycle(graph: dict[str, dict[str, int]]) -> list[str] | None:
    """One cycle of the graph as a list of nodes (first == last), or None."""
    state: dict[str, int] = {}  # 1: on the stack, 2: done
    stack: list[str] = []

    def visit(n: str) -> list[str] | None:
        state[n] = 1
        stack.append(n)
        for m in sorted(graph[n]):
            if state.get(m) == 1:
                return [*stack[stack.index(m) :], m]
            if m not in state:
                found = visit(m)
                if found:
                    return found
        stack.pop()
        state[n] = 2
        return None

    for n in sorted(graph):
        if n not in state:
            found = visit(n)
            if found:
                return found
    return None


def order(graph: dict[str, dict[str, int]]) -> list[str]:
    """The modules in dependency order, lowest first (ties by name)."""
    done: list[str] = []
    left = set(graph)
    while left:
        ready = sorted(n for n in left if all(m in done for m in graph[n]))
        done += ready
        left -= set(ready)
    return done


def main(argv: list[str]) -> int:
    quiet = "--quiet" in argv
    args = [a for a in argv if not a.startswith("--")]
    src = Path(args[0]) if args else Path(__file__).resolve().parent.parent / "rust" / "src"
    graph = edges(src)
    cycle = find_cycle(graph)
    if not quiet or cycle:
        for a in sorted(graph):
            deps = ", ".join(f"{b} ({n})" for b, n in sorted(graph[a].items()))
            print(f"{a} -> {deps or '-'}")
    if cycle:
        print("cycle between top-level modules: " + " -> ".join(cycle), file=sys.stderr)
        return 1
    print("no cycle; dependency order (lowest first): " + " < ".join(order(graph)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
