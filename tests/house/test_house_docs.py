"""The documents hold what they claim: the README for users within its size, and every module,
class or function the architecture and numerics documents name exists.

A newcomer finds a concept in one hop from `.docs/architecture.md`, so a name there that no
longer exists (a module moved, a function renamed) is a broken hop: these tests fail on it.
"""

from __future__ import annotations

import importlib
import re

import pytest
from support.paths import ROOT

#: The README is the user's guide: developer material lives in .docs/.
README_MOST_LINES = 450
#: A dotted name of the project in backticks: `core.x`, `app.viewer.y.z`, with an optional call.
DOTTED = re.compile(r"`((?:core|app)(?:\.[A-Za-z_][A-Za-z0-9_]*)+)(?:\(\))?`")


def dotted_names(text: str) -> set[str]:
    """The project's dotted names written in backticks in `text`."""
    return set(DOTTED.findall(text))


def missing(names: set[str]) -> list[str]:
    """The names of `names` that resolve to no module, or attribute of a module, of the project."""
    gone = []
    for name in sorted(names):
        parts = name.split(".")
        for split in range(len(parts), 0, -1):
            try:
                target = importlib.import_module(".".join(parts[:split]))
            except ImportError:
                continue
            for attribute in parts[split:]:
                target = getattr(target, attribute, None)
                if target is None:
                    break
            if target is None:
                gone.append(name)
            break
        else:
            gone.append(name)
    return gone


def test_the_readme_is_for_users_and_short():
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= README_MOST_LINES
    assert "previous release" not in text


@pytest.mark.parametrize("document", ["architecture.md", "numerics.md", "performance.md", "limits.md"])
def test_every_name_the_documents_give_exists(document):
    names = dotted_names((ROOT / ".docs" / document).read_text())
    assert missing(names) == []


def test_the_check_finds_a_name_that_is_gone():
    names = dotted_names(
        "see `core.curves.bspline`, `core.layer_compiled.knot_blocks` and `app.warp.job.run_job`"
    )
    assert names == {"core.curves.bspline", "core.layer_compiled.knot_blocks", "app.warp.job.run_job"}
    assert missing(names) == ["core.layer_compiled.knot_blocks"]
    assert missing({"core.curves.bspline.NoSuchThing"}) == ["core.curves.bspline.NoSuchThing"]
