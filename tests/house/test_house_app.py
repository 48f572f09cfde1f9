"""The sizes that keep app/ readable (issue 35): no import cycle, files of at most 900 lines,
functions of at most 100, classes of at most 15 fields, and the viewer's test hook outside its
model.  Every rule is measured with `ast` and checked on a bad snippet first, so that none of
them can pass by measuring nothing."""

from __future__ import annotations

import ast
import textwrap
from pathlib import Path

from support.imports import find_cycle, import_graph
from support.paths import ROOT

MAX_FILE_LINES = 900
MAX_FUNCTION_LINES = 100
MAX_CLASS_FIELDS = 15
#: The window class only wires the viewer's parts (napari's Window over its ViewerModel).
MAX_VIEWER_LINES = 400
#: The viewer's model: the classes whose fields are the state `gui` and the controller share.
MODEL_MODULE = "app/viewer/state.py"
#: What only tests read (the window points of some widgets): kept by the GUI, not the model.
TEST_HOOKS = {"spots"}


def app_files() -> list[Path]:
    return sorted((ROOT / "app").rglob("*.py"))


def long_functions(source: str, limit: int = MAX_FUNCTION_LINES) -> list[tuple[str, int]]:
    """(qualified name, lines) of every function or method of `source` longer than `limit` lines,
    decorators and docstring included."""
    found = []

    def visit(node, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                name = f"{prefix}{child.name}"
                if not isinstance(child, ast.ClassDef):
                    first = min([child.lineno] + [d.lineno for d in child.decorator_list])
                    if child.end_lineno - first + 1 > limit:
                        found.append((name, child.end_lineno - first + 1))
                visit(child, f"{name}.")
            else:
                visit(child, prefix)

    visit(ast.parse(source), "")
    return found


def class_fields(node: ast.ClassDef) -> set[str]:
    """The fields of a class: annotated names in its body (dataclass fields) and the attributes
    its ``__init__`` assigns on ``self`` (``self.x = ...``, ``self.x: T = ...``, ``self.x, self.y = ...``)."""
    fields = {
        statement.target.id
        for statement in node.body
        if isinstance(statement, ast.AnnAssign) and isinstance(statement.target, ast.Name)
    }
    for statement in node.body:
        if isinstance(statement, ast.FunctionDef) and statement.name == "__init__":
            for inner in ast.walk(statement):
                targets = []
                if isinstance(inner, ast.Assign):
                    targets = inner.targets
                elif isinstance(inner, (ast.AnnAssign, ast.AugAssign)):
                    targets = [inner.target]
                for target in targets:
                    for leaf in ast.walk(target):
                        if (
                            isinstance(leaf, ast.Attribute)
                            and isinstance(leaf.value, ast.Name)
                            and leaf.value.id == "self"
                        ):
                            fields.add(leaf.attr)
    return fields


def class_lines(source: str, name: str) -> int:
    """Lines of the class `name` of `source`, decorators and docstring included (0 if absent)."""
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ClassDef) and node.name == name:
            return node.end_lineno - min([node.lineno] + [d.lineno for d in node.decorator_list]) + 1
    return 0


def crowded_classes(source: str, limit: int = MAX_CLASS_FIELDS) -> list[tuple[str, int]]:
    """(name, fields) of every class of `source` with more than `limit` fields (`class_fields`)."""
    return [
        (node.name, len(class_fields(node)))
        for node in ast.walk(ast.parse(source))
        if isinstance(node, ast.ClassDef) and len(class_fields(node)) > limit
    ]


def model_fields(source: str) -> set[str]:
    """Every field of every class of the model's `source`."""
    return set().union(
        *(class_fields(node) for node in ast.walk(ast.parse(source)) if isinstance(node, ast.ClassDef))
    )


BAD = textwrap.dedent(
    """
    from dataclasses import dataclass

    @dataclass
    class Wide:
    {fields}

    class Busy:
        def __init__(self):
    {assignments}
            self.a, self.b = 1, 2

    def long():
    {body}
    """
)


def bad_snippet(fields: int, assignments: int, body: int) -> str:
    return BAD.format(
        fields="\n".join(f"    field_{k}: int = {k}" for k in range(fields)),
        assignments="\n".join(f"        self.x_{k} = {k}" for k in range(assignments)),
        body="\n".join(f"    x_{k} = {k}" for k in range(body)) + "\n    return 0",
    )


def test_the_helpers_catch_a_bad_snippet():
    bad = bad_snippet(fields=16, assignments=14, body=99)
    # 16 annotated fields; 14 assignments + a and b; def line + 99 + return = 101 lines.
    assert crowded_classes(bad) == [("Wide", 16), ("Busy", 16)]
    assert long_functions(bad) == [("long", 101)]
    assert "field_3" in model_fields(bad) and "x_13" in model_fields(bad)
    good = bad_snippet(fields=15, assignments=13, body=98)
    assert crowded_classes(good) == [] and long_functions(good) == []
    # @dataclass, the class line and 16 fields; the def line, 14 + 1 assignments.
    assert class_lines(bad, "Wide") == 18 and class_lines(bad, "Busy") == 17 and class_lines(bad, "None") == 0


def test_methods_are_measured_by_their_qualified_name():
    source = "class A:\n    def f(self):\n" + "        x = 1\n" * 100
    assert long_functions(source) == [("A.f", 101)]


def test_the_cycle_helper_sees_app():
    # import_graph must see app's modules and their imports, or "no cycle" would be empty.
    graph = import_graph("app")
    assert "app.viewer.window" in graph and "app.viewer.controller" in graph["app.viewer.window"]


def test_app_has_no_import_cycle():
    assert find_cycle(import_graph("app")) == []


def test_app_files_are_at_most_900_lines():
    lines = {path.relative_to(ROOT).as_posix(): len(path.read_text().splitlines()) for path in app_files()}
    assert lines and {name: count for name, count in lines.items() if count > MAX_FILE_LINES} == {}


def test_app_functions_are_at_most_100_lines():
    long = {
        f"{path.relative_to(ROOT).as_posix()}:{name}": count
        for path in app_files()
        for name, count in long_functions(path.read_text())
    }
    assert long == {}


def test_app_classes_have_at_most_15_fields():
    crowded = {
        f"{path.relative_to(ROOT).as_posix()}:{name}": count
        for path in app_files()
        for name, count in crowded_classes(path.read_text())
    }
    assert crowded == {}


def test_the_viewer_model_holds_no_test_hook():
    fields = model_fields((ROOT / MODEL_MODULE).read_text())
    assert "live" in fields or "history" in fields  # the model is where the test looks
    assert fields & TEST_HOOKS == set()


def test_the_viewer_window_class_is_at_most_400_lines():
    assert 0 < class_lines((ROOT / "app/viewer/window.py").read_text(), "Viewer") <= MAX_VIEWER_LINES
