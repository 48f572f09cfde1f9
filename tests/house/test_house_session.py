"""One session model (issue 49): `app.io.session` alone reads session keys out of a dict; every
other module of `app` takes them from the typed `Session`.  The check is tried on bad snippets first."""

from __future__ import annotations

import ast

from support.paths import ROOT

from app.io.session import OPTIONAL_KEYS, REQUIRED_KEYS

SESSION_MODULE = "app/io/session.py"
#: Session keys that other dicts of the app use as well (the parser's subcommands, GL objects by
#: name, kernel keyword arguments, the studies' summaries, the viewer worker's messages, the moves
#: of a demo script): a read of one of them is not told from a session's by the key alone, so only
#: the others are looked for.
SHARED_WORDS = {"image", "view", "kernel", "cage", "parameterization", "outside", "background", "fold_free"}
SESSION_ONLY_KEYS = {*REQUIRED_KEYS, *OPTIONAL_KEYS} - SHARED_WORDS


def dict_reads(source: str, keys: set[str]) -> list[str]:
    """``line: key`` of each read of one of `keys` out of a dict in `source`: ``value["key"]``,
    ``value.get("key")``, ``.pop`` or ``.setdefault`` (a key written, ``value["key"] = x``, too)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        key = None
        if isinstance(node, ast.Subscript) and isinstance(node.slice, ast.Constant):
            key = node.slice.value
        elif (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Attribute)
            and node.func.attr in ("get", "pop", "setdefault")
            and node.args
            and isinstance(node.args[0], ast.Constant)
        ):
            key = node.args[0].value
        if isinstance(key, str) and key in keys:
            found.append(f"{node.lineno}: {key}")
    return found


def test_the_check_finds_session_keys_read_out_of_a_dict():
    bad = (
        "value = read_json(path)\n"
        'fill = value.get("fill", "none")\n'
        'frames = value["keyframes"]\n'
        'extra.pop("history")\n'
    )
    assert dict_reads(bad, SESSION_ONLY_KEYS) == ["2: fill", "3: keyframes", "4: history"]
    good = 'session = read_session(path)\nfill = session.output.fill\nsteps = params.get("power")\n'
    assert dict_reads(good, SESSION_ONLY_KEYS) == []
    assert {"fill", "keyframes", "kernel_params", "pins", "max_distortion"} <= SESSION_ONLY_KEYS


def test_only_the_session_model_reads_session_keys_out_of_a_dict():
    offenders = {
        path.relative_to(ROOT).as_posix(): reads
        for path in sorted((ROOT / "app").rglob("*.py"))
        if path.relative_to(ROOT).as_posix() != SESSION_MODULE
        and (reads := dict_reads(path.read_text(), SESSION_ONLY_KEYS))
    }
    assert offenders == {}
    assert dict_reads((ROOT / SESSION_MODULE).read_text(), SESSION_ONLY_KEYS) != []  # where it looks
