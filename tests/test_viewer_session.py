"""Opening and saving viewer documents (app.viewer.session) and the session keys `warp` reads."""

import json
from pathlib import Path

import numpy as np
import pytest

from app.files import InputError, Session, read_session, session_kernel_params, session_max_edge
from app.render import View
from app.viewer import session as sessions
from app.viewer.demos import demo_files
from app.viewer.state import AppState, History


@pytest.fixture(autouse=True)
def state_directory(tmp_path, monkeypatch):
    monkeypatch.setenv("TRANSFINITE_STATE_DIR", str(tmp_path / "state"))


def test_default_paths(tmp_path):
    assert sessions.default_session_path("my image") == tmp_path / "state" / "sessions" / "my_image.json"


def test_open_a_demo_an_image_and_fit(tmp_path):
    document = sessions.open_document()
    assert document.snapshot.image.name == "starfish.png" and document.view is None
    assert np.array_equal(document.snapshot.cage, document.snapshot.target)
    assert document.session_path.name == "starfish.json"
    files = demo_files("pattern")
    fitted = sessions.open_document(files.image)  # no cage: fitted to the silhouette
    assert 10 <= fitted.snapshot.n <= 16
    blank = tmp_path / "blank.png"
    from app.files import write_png

    write_png(blank, np.full((12, 10, 4), 255, np.uint8))
    document = sessions.open_document(blank)  # nothing to fit with 16 points: an ellipse
    assert document.snapshot.n == 12
    note = sessions.fit_or_ellipse(np.full((12, 10, 4), 255, np.uint8))[1]
    assert note.startswith("no silhouette to fit")


def test_save_and_restore_everything(tmp_path):
    files = demo_files("starfish")
    path = tmp_path / "s.json"
    document = sessions.open_document(files.image, files.cage, path)
    snapshot = document.snapshot.replace(kernel="power", power=3.0, shift="none")
    target = snapshot.target.copy()
    target[2] += [12, -4]
    snapshot = snapshot.replace(target=target)
    state = AppState(History(snapshot), snapshot, document.image, path, view=View(1.25, (310.0, 7.5)))
    state.mode, state.content, state.selected = "cage", "height", 2
    sessions.save(state, 2.5)
    stored = json.loads(path.read_text())
    assert stored["kernel_params"] == {"power": 3.0, "shift": "none"}
    assert stored["mesh"] == {"max_edge": 2.5}
    assert stored["image"] == str(Path("..") / "..") or stored["image"].endswith("starfish.png")
    restored = sessions.restore(path)
    assert restored.snapshot == snapshot and restored.view == View(1.25, (310.0, 7.5))
    assert restored.max_edge == 2.5
    again = AppState(History(restored.snapshot), restored.snapshot, restored.image, path)
    sessions.apply_preferences(again, restored.preferences)
    assert (again.mode, again.content, again.selected) == ("cage", "height", 2)
    with pytest.raises(InputError, match="exists: open it alone with --session"):
        sessions.open_document(files.image, None, path)


def session_with(extra, kernel="power"):
    points = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    return Session(Path("x.png"), points, points, kernel, extra=extra)


def test_session_kernel_params_and_mesh_are_validated():
    assert session_kernel_params(session_with({})) == {}
    assert session_kernel_params(session_with({"kernel_params": {"power": 2, "shift": "mean"}})) == {
        "power": 2.0,
        "shift": "mean",
    }
    for extra, message in [
        ({"kernel_params": []}, "must be an object"),
        ({"kernel_params": {"power": -1}}, "power must be a number > 0"),
        ({"kernel_params": {"shift": "up"}}, "shift must be"),
        ({"kernel_params": {"gamma": 1}}, "unknown kernel parameter"),
    ]:
        with pytest.raises(InputError, match=message):
            session_kernel_params(session_with(extra))
    with pytest.raises(InputError, match="takes no parameters"):
        session_kernel_params(session_with({"kernel_params": {"power": 2}}, kernel="mean-value"))
    assert session_max_edge(session_with({})) is None
    assert session_max_edge(session_with({"mesh": {"max_edge": 3}})) == 3.0
    with pytest.raises(InputError, match="max_edge must be a number > 0"):
        session_max_edge(session_with({"mesh": {"max_edge": "big"}}))


def test_a_saved_session_reads_back_with_the_shared_reader(tmp_path):
    files = demo_files("character")
    path = tmp_path / "c.json"
    document = sessions.open_document(files.image, files.cage, path)
    state = AppState(History(document.snapshot), document.snapshot, document.image, path)
    sessions.save(state, None)
    session = read_session(path)
    assert session.image.resolve() == files.image.resolve() and session.kernel == "harmonic-like"
    assert "mesh" not in session.extra and "kernel_params" not in session.extra
