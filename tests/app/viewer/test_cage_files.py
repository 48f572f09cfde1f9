"""The viewer's cage files (app.viewer.cage_files): open a JSON or SVG cage, save the cage or target."""

from pathlib import Path

import numpy as np
import pytest

from app.io.files import read_cage
from app.viewer import cage_files, commands
from app.viewer.state import AppState, Document, History, Snapshot
from core import examples

STAR = examples.starfish(points_per_arm=2) * np.array([150.0, -150.0]) + np.array([320.0, 240.0])


@pytest.fixture
def state(tmp_path):
    snapshot = Snapshot(Path("star.png"), STAR, STAR + [5.0, -3.0])
    image = np.zeros((480, 640, 4), np.uint8)
    return AppState(Document(History(snapshot), snapshot, image, tmp_path / "star.json"))


@pytest.mark.parametrize("which", cage_files.SAVED)
def test_saved_as_svg_and_opened_again_the_cage_is_exact_and_one_undo_step(state, tmp_path, which):
    path = cage_files.proposed_path(state, which)
    assert path == tmp_path / f"star.{which}.svg"
    cage_files.save_cage(state, which, path)
    assert state.status_message() == f"saved the {which} to {path}"
    assert 'width="640" height="480"' in path.read_text()
    saved = getattr(state.document.live, which)
    before = state.document.live
    cage_files.open_cage(state, path)
    np.testing.assert_allclose(state.document.live.cage, saved, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(state.document.live.target, state.document.live.cage)
    commands.command(state, "undo")
    assert state.document.live == before


def test_a_fitted_svg_says_so_on_the_status_line(state, tmp_path):
    (tmp_path / "square.svg").write_text(
        '<svg xmlns="http://www.w3.org/2000/svg"><rect x="100" y="80" width="300" height="200"/></svg>'
    )
    cage_files.open_cage(state, tmp_path / "square.svg")
    assert "the path is not a quadratic B-spline; fitted" in state.status_message()
    assert len(state.document.live.cage) >= 8


def test_save_refuses_a_name_that_is_no_cage_file(state, tmp_path):
    cage_files.save_cage(state, "cage", tmp_path / "cage.png")
    assert (
        state.status.message_is_error and "a cage file's name ends in .json or .svg" in state.status.message
    )
    assert not (tmp_path / "cage.png").exists()


def test_saved_as_json_it_reads_back_rounded(state, tmp_path):
    cage_files.save_cage(state, "target", tmp_path / "t.json")
    np.testing.assert_allclose(read_cage(tmp_path / "t.json"), STAR + [5.0, -3.0], atol=5e-4)
