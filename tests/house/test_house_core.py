"""The numbers that keep core/ a house a newcomer can walk (issue 35): no import circle, no
module using another's private names, at most 10 modules at the top, files and functions of a
size one can read, and numba state passed as named tuples rather than long lists of arrays.

Every check is a function of source text (`ast`), so each is also run on a deliberately bad
snippet, to show that it can fail."""

from __future__ import annotations

import ast
import textwrap
from pathlib import Path

from support.imports import find_cycle, import_graph, module_names
from support.paths import ROOT

CORE = ROOT / "core"

MAX_TOP_LEVEL_MODULES = 10
MAX_FILE_LINES = 900
MAX_FUNCTION_LINES = 100
MAX_PARAMETERS = 12
MAX_COMPILED_POSITIONAL = 8


def private_uses(modules: dict[str, Path]) -> list[str]:
    """Every use of another module's private (``_name``, not dunder) name among `modules`
    (dotted name -> file): ``from a.b import _x`` and ``b._x`` where ``b`` is a module of the
    package, at the top of a file or inside a function."""
    offenders = []
    for name, path in modules.items():
        tree = ast.parse(path.read_text())
        aliases = {}  # local name -> module of the package it is bound to
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name in modules and alias.asname:
                        aliases[alias.asname] = alias.name
            elif isinstance(node, ast.ImportFrom) and node.module:
                for alias in node.names:
                    if f"{node.module}.{alias.name}" in modules:
                        aliases[alias.asname or alias.name] = f"{node.module}.{alias.name}"
                    elif node.module in modules and node.module != name and _private(alias.name):
                        offenders.append(f"{name}: from {node.module} import {alias.name}")
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and _private(node.attr):
                owner = aliases.get(_dotted(node.value)) or _dotted(node.value)
                if owner in modules and owner != name:
                    offenders.append(f"{name}: {owner}.{node.attr}")
    return sorted(offenders)


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _dotted(node: ast.AST) -> str:
    """``a.b.c`` for a chain of attributes on a name, else ''."""
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute) and (base := _dotted(node.value)):
        return f"{base}.{node.attr}"
    return ""


def functions(path: Path) -> list[ast.FunctionDef | ast.AsyncFunctionDef]:
    return [
        node
        for node in ast.walk(ast.parse(path.read_text()))
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
    ]


def parameter_count(function: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """Every parameter, ``self`` and ``*args`` / ``**kwargs`` included."""
    arguments = function.args
    named = arguments.posonlyargs + arguments.args + arguments.kwonlyargs
    return len(named) + (arguments.vararg is not None) + (arguments.kwarg is not None)


def compiled(function: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    """Decorated with numba's ``njit`` (bare, called or as ``numba.njit``)."""
    for decorator in function.decorator_list:
        target = decorator.func if isinstance(decorator, ast.Call) else decorator
        if _dotted(target) in ("njit", "numba.njit"):
            return True
    return False


def oversized(paths: list[Path]) -> dict[str, list[str]]:
    """What breaks the size rules among `paths`: long files, long functions, functions with too
    many parameters, compiled functions with too many positional parameters (each of them an
    array or a scalar: the count bounds the arrays)."""
    found = {"files": [], "functions": [], "parameters": [], "compiled": []}
    for path in paths:
        lines = len(path.read_text().splitlines())
        if lines > MAX_FILE_LINES:
            found["files"].append(f"{path.name}: {lines} lines")
        for function in functions(path):
            where = f"{path.name}:{function.lineno} {function.name}"
            length = function.end_lineno - function.lineno + 1
            if length > MAX_FUNCTION_LINES:
                found["functions"].append(f"{where}: {length} lines")
            if parameter_count(function) > MAX_PARAMETERS:
                found["parameters"].append(f"{where}: {parameter_count(function)} parameters")
            positional = len(function.args.posonlyargs + function.args.args)
            if compiled(function) and positional > MAX_COMPILED_POSITIONAL:
                found["compiled"].append(f"{where}: {positional} positional parameters")
    return found


def core_files() -> list[Path]:
    return sorted(CORE.rglob("*.py"))


def test_core_has_no_import_cycle_at_the_top_or_in_functions():
    assert find_cycle(import_graph("core")) == []


def test_no_core_module_uses_another_modules_private_names():
    assert private_uses(module_names("core")) == []


def test_at_most_ten_modules_at_the_top_of_core():
    top = sorted(path.name for path in CORE.glob("*.py"))
    assert len(top) <= MAX_TOP_LEVEL_MODULES, top


def test_core_files_and_functions_are_of_a_readable_size():
    assert oversized(core_files()) == {"files": [], "functions": [], "parameters": [], "compiled": []}


def bad_package(folder: Path) -> dict[str, Path]:
    """A package `bad` that breaks every rule once: a cycle through a function-level import,
    a private import, a private attribute, a long file, a long function, too many parameters."""
    package = folder / "bad"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "a.py").write_text("from bad.b import _hidden\n\ndef f():\n    return _hidden\n")
    (package / "b.py").write_text(
        textwrap.dedent(
            """\
            from bad import c
            _hidden = 1

            def g():
                from bad import a  # a cycle, inside a function
                return c._secret + a.f()
            """
        )
    )
    many = ", ".join(f"p{i}" for i in range(13))
    body = "\n".join(f"    x{i} = {i}" for i in range(101))
    (package / "c.py").write_text(
        f"from numba import njit\n_secret = 2\n\n\n@njit(cache=True)\ndef h({many}):\n{body}\n" + "\n" * 900
    )
    return {
        ".".join(path.relative_to(folder).with_suffix("").parts).removesuffix(".__init__"): path
        for path in sorted(package.rglob("*.py"))
    }


def test_the_checks_find_what_a_bad_package_breaks(tmp_path, monkeypatch):
    modules = bad_package(tmp_path)
    assert private_uses(modules) == ["bad.a: from bad.b import _hidden", "bad.b: bad.c._secret"]
    monkeypatch.setattr("support.imports.ROOT", tmp_path)
    assert find_cycle(import_graph("bad")) == ["bad.a", "bad.b", "bad.a"]
    found = oversized(sorted(modules.values()))
    assert [entry.split(":")[0] for entry in found["files"]] == ["c.py"]
    assert found["functions"] == ["c.py:6 h: 102 lines"]
    assert found["parameters"] == ["c.py:6 h: 13 parameters"]
    assert found["compiled"] == ["c.py:6 h: 13 positional parameters"]
