"""The import graph of a package, from its source, and a cycle in it."""

from __future__ import annotations

import ast
from pathlib import Path

from support.paths import ROOT


def module_names(package: str) -> dict[str, Path]:
    """Dotted name -> file of every module of `package` (a folder at the top of the repository)."""
    names = {}
    for path in sorted((ROOT / package).rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        names[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return names


def import_graph(package: str) -> dict[str, set[str]]:
    """Every module of `package` -> the modules of `package` it imports, at the top or in a function."""
    modules = module_names(package)
    graph = {}
    for name, path in modules.items():
        imported = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                imported |= {alias.name for alias in node.names}
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    here = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
                    base = ".".join(here[: len(here) - node.level + 1] + ([base] if base else []))
                for alias in node.names:
                    # `from package import module` imports the module, `from module import name` the module.
                    imported.add(f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base)
        graph[name] = {target for target in imported if target in modules and target != name}
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str]:
    """One import cycle of `graph` as [a, b, ..., a], or [] if there is none (depth-first search)."""
    state = dict.fromkeys(graph, "new")
    path: list[str] = []

    def visit(node):
        state[node] = "on path"
        path.append(node)
        for target in sorted(graph[node]):
            if state[target] == "on path":
                return path[path.index(target) :] + [target]
            if state[target] == "new" and (cycle := visit(target)):
                return cycle
        state[node] = "done"
        path.pop()
        return []

    for node in sorted(graph):
        if state[node] == "new" and (cycle := visit(node)):
            return cycle
    return []
