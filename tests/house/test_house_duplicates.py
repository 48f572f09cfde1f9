"""The house's sixth rule (issue 49 item 6): at most `MAX_DUPLICATES` places in `core/` and `app/`
together that repeat six lines or more of another, counted as the ``duplicates`` tool counts them
(``duplicates --repo core``, ``--repo app``; its rows marked ``boilerplate`` left aside).

A place is a run of `WINDOW` code lines (blank lines, comments, docstring openings, imports and
lone punctuation passed over; white space folded) that stands again elsewhere, either to the letter
or in the same shape with other names, strings and numbers.  A pair of files counts once, however
many runs they share; it is boilerplate where it shares only shapes and most of those are thin
(mostly punctuation and keywords) or recur in three files of one folder.  The counter is checked on
bad snippets first, so that it cannot pass by finding nothing."""

from __future__ import annotations

import hashlib
import re
import textwrap
from collections import defaultdict
from pathlib import Path

from support.paths import ROOT

MAX_DUPLICATES = 5
#: Lines a run shares, and the places one run may stand in before it is too common to count.
WINDOW = 6
MOST_PLACES = 8
#: A shape window needs this many tokens a line on average and this many statements.
MIN_TOKENS = 4
MIN_STATEMENTS = 2
#: A window is thin where more than this share of its tokens are punctuation or keywords.
THIN_SHARE = 0.6
#: A shape standing in this many files of one folder is that folder's plumbing.
PLUMBING_FILES = 3

_TOKEN = re.compile(r"\"(?:[^\"\\]|\\.)*\"|'(?:[^'\\]|\\.)*'|[A-Za-z_]\w*|[0-9][0-9a-fA-FxX_.]*|\S")
_PUNCTUATION_ONLY = re.compile(r"[\s{}()\[\];,:.]*")
_ASIDE = ("#", "/*", "*", "'''", '"""')
#: Import lines, in the words of every language the tool reads (a docstring line may read so too).
_HEADER = re.compile(
    r"^(import\b|from \S+ import\b|use [\w:{]|(pub(\([\w:]+\))? )?(use|mod) [\w:{]+;?$"
    r"|#\s*(?:include|import)\b|package [\w.]+;?$"
    r"|(const |var |let )?[\w{}, ]+ = require\(|export \{[^}]*\} from )"
)
_OPERAND = r"(?:[sx0_](?: [:.] [:.]? ?x)*(?: \( [sx0_ .:,]*\)?)?)"
#: A line that pairs a key with a value (``"a": b,``): data, not a statement.
_KEY_VALUE = re.compile(rf"^(?:x )?{_OPERAND} (?:= >|:|- >) (?:x )?{_OPERAND} [,;]?$")
_STATEMENT_WORDS = set(
    "if for while loop return let var const else elif try except catch with raise throw yield await defer go"
    " do unsafe assert del goto continue break".split()
)
_DECLARATION_WORDS = set("impl class struct enum interface trait union typedef pub export".split())
_KEYWORDS = (
    _STATEMENT_WORDS
    | _DECLARATION_WORDS
    | set(
        "case switch default func def fn function nil null none None true false err error self this new end"
        " then in not and or static void int bool string public private final mut match Ok Err Some".split()
    )
)


def _line(text: str):
    """(folded text, shape, is a statement, tokens, thin tokens) of a code line, None where it does
    not count."""
    folded = " ".join(text.split())
    if not 3 <= len(folded) <= 2000 or _PUNCTUATION_ONLY.fullmatch(folded):
        return None
    if folded.startswith(_ASIDE) and not folded.startswith("*/") or _HEADER.match(folded):
        return None
    tokens = _TOKEN.findall(folded)
    names = [t for t in tokens if t[0].isalpha() or t[0] == "_"]
    shape = [
        "x" if t[0].isalpha() or t[0] == "_" else "s" if t[0] in "\"'" else "0" if t[0].isdigit() else t
        for t in tokens
    ]
    thin = sum(t not in ("x", "s", "0") for t in shape) + sum(n in _KEYWORDS for n in names)
    return folded, " ".join(shape), _is_statement(shape, names), len(shape), thin


def _is_statement(shape: list[str], names: list[str]) -> bool:
    if not shape or shape[0] == "#" or _KEY_VALUE.match(" ".join(shape)):
        return False
    if names and names[0] in _STATEMENT_WORDS:
        return True
    if names and names[0] in _DECLARATION_WORDS and shape[-1] in "{(:" and "=" not in shape:
        return False
    for k, token in enumerate(shape):
        alone = k + 1 >= len(shape) or shape[k + 1] not in "=>"
        if token == "=" and alone and (k == 0 or shape[k - 1] not in "=!<>"):
            return True
    return len(shape) >= 8


def _key(parts) -> str:
    return hashlib.blake2b("\n".join(parts).encode(), digest_size=10).hexdigest()


def _windows(source: str):
    """(exact key, shape key or '', first line, last line, thin) of every run of `WINDOW` counted lines."""
    rows = [(number, row) for number, text in enumerate(source.split("\n"), 1) if (row := _line(text))]
    for i in range(len(rows) - WINDOW + 1):
        chunk = [row for _, row in rows[i : i + WINDOW]]
        count = sum(row[3] for row in chunk)
        slight = count < MIN_TOKENS * WINDOW or sum(row[2] for row in chunk) < MIN_STATEMENTS
        shape = "" if slight else _key(row[1] for row in chunk)
        thin = sum(row[4] for row in chunk) > THIN_SHARE * max(1, count)
        yield _key(row[0] for row in chunk), shape, rows[i][0], rows[i + WINDOW - 1][0], thin


def duplicated_pairs(sources: dict[str, str]) -> list[str]:
    """The pairs of places (``a.py:10-15 ~ b.py:40-45``, the first run of each pair of files) that
    share a run of `WINDOW` lines among `sources` (path relative to the package -> text), boilerplate
    left aside."""
    exact, shaped = defaultdict(set), defaultdict(set)
    for path in sorted(sources):
        for exact_key, shape_key, first, last, thin in _windows(sources[path]):
            exact[exact_key].add((path, first, last, thin))
            if shape_key:
                shaped[shape_key].add((path, first, last, thin))
    hits, solid, kinds = defaultdict(set), defaultdict(int), {}
    for kind, groups in (("exact", exact), ("shape", shaped)):
        for places in groups.values():
            if len(places) > MOST_PLACES:
                continue
            places = sorted(places)
            folders = defaultdict(set)
            for place in places:
                folders[place[0].rpartition("/")[0]].add(place[0])
            plumbing = kind == "shape" and max(len(files) for files in folders.values()) >= PLUMBING_FILES
            for j, (file_a, a1, a2, thin_a) in enumerate(places):
                for file_b, b1, b2, thin_b in places[j + 1 :]:
                    if file_a == file_b and b1 <= a2:  # overlapping runs of one file
                        continue
                    hits[file_a, file_b].add((a1, a2, b1, b2))
                    solid[file_a, file_b] += not (plumbing or (kind == "shape" and thin_a and thin_b))
                    kinds.setdefault((file_a, file_b), kind)
    return sorted(
        f"{a}:{a1}-{a2} ~ {b}:{b1}-{b2}"
        for (a, b), found in hits.items()
        if not (kinds[a, b] == "shape" and 2 * solid[a, b] < len(found))
        for a1, a2, b1, b2 in [min(found)]
    )


def package_sources(package: Path) -> dict[str, str]:
    return {str(path.relative_to(package)): path.read_text() for path in sorted(package.rglob("*.py"))}


def _function(name: str, words: tuple[str, str, str]) -> str:
    first, second, third = words
    return textwrap.dedent(f'''
        def {name}(points, scale):
            """What it does."""
            {first} = points.mean(axis=0)
            {second} = (points - {first}) * scale
            if {second}.size == 0:
                raise ValueError("no {third} given")
            {third} = {second}.max(axis=0) - {second}.min(axis=0)
            return {first}, {second}, {third}
        ''')


def test_the_counter_finds_a_copy_and_a_renamed_copy_but_not_boilerplate_or_a_short_run():
    copied = ("centre", "moved", "extent")
    renamed = ("middle", "shifted", "span")
    assert duplicated_pairs({"a.py": _function("f", copied), "b.py": _function("g", copied)}) == [
        "a.py:2-8 ~ b.py:2-8"
    ]
    assert duplicated_pairs({"a.py": _function("f", copied), "sub/c.py": _function("h", renamed)}) == [
        "a.py:2-8 ~ sub/c.py:2-8"
    ]
    # One file repeating itself is a pair too; imports, comments and docstrings are not code lines.
    doubled = _function("f", copied) + "\n# a comment\nimport os\n" + _function("g", renamed)
    assert duplicated_pairs({"a.py": doubled}) == ["a.py:2-8 ~ a.py:14-20"]
    # The same shape in three files of one folder is its plumbing, not a duplicate.
    three = {
        f"pkg/{name}.py": _function(name, words)
        for name, words in zip("pqr", [copied, renamed, renamed], strict=True)
    }
    three["pkg/q.py"] = three["pkg/q.py"].replace("(axis=0)", "(axis=1)")
    three["pkg/r.py"] = three["pkg/r.py"].replace("(axis=0)", "(axis=2)")
    assert duplicated_pairs(three) == []
    assert duplicated_pairs({path: three[path] for path in ("pkg/p.py", "pkg/q.py")}) == [
        "pkg/p.py:2-8 ~ pkg/q.py:2-8"
    ]
    # Five shared lines are not a run: the heading and the last line differ in shape too.
    other = _function("f", copied).replace("scale)", "scale, *, extra=None)")
    other = other.replace("return centre, moved, extent", "print(extent)")
    assert duplicated_pairs({"a.py": _function("f", copied), "b.py": other}) == []


def test_core_and_app_repeat_themselves_in_at_most_five_places():
    found = [
        f"{name}/{pair}"
        for name in ("core", "app")
        for pair in duplicated_pairs(package_sources(ROOT / name))
    ]
    assert len(found) <= MAX_DUPLICATES, "\n".join(found)
