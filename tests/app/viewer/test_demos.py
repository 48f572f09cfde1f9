"""The bundled demos and scripted replays (app.viewer.demos)."""

import json

import numpy as np
import pytest

import core
from app.io.files import InputError, read_cage, read_image
from app.viewer import demos
from app.viewer.demos import DEMOS, Move, ScriptPlayer, demo_files, read_script


@pytest.mark.parametrize("name", list(DEMOS))
def test_bundled_demo_assets_are_valid(name):
    files = demo_files(name)
    assert files.image.parent == demos.ASSETS  # shipped in assets/
    image = read_image(files.image)
    assert image.shape == (480, 640, 4)
    cage = read_cage(files.cage)
    curve = core.ClosedBSpline(cage)  # a simple closed curve
    assert curve.diameter > 300
    moves = read_script(files.script, len(cage))
    assert len(moves) >= 2


@pytest.mark.parametrize("name", list(DEMOS))
def test_the_drawn_shape_lies_inside_its_cage(name):
    image, cage, _ = DEMOS[name].draw()
    outline = core.ClosedBSpline(cage)
    # The shape is what differs from the background colour at the image's corner.
    background = image[2, 2, :3].astype(int)
    different = np.abs(image[..., :3].astype(int) - background).max(axis=-1) > 60
    # Sample the figure's pixels (the starfish's sand is textured: look at its orange body only).
    rows, cols = np.nonzero(different)
    pick = np.random.default_rng(0).choice(len(rows), size=min(400, len(rows)), replace=False)
    points = np.stack([cols[pick] + 0.5, rows[pick] + 0.5], axis=1)
    if name == "starfish":
        hue = image[rows[pick], cols[pick], :3].astype(int)
        points = points[(hue[:, 0] - hue[:, 2]) > 120]  # orange, not sand
    assert outline.contains(points).mean() > 0.99


def test_demos_are_drawn_again_when_assets_are_missing(tmp_path, monkeypatch):
    monkeypatch.setattr(demos, "ASSETS", tmp_path / "missing")
    monkeypatch.setenv("TRANSFINITE_CACHE_DIR", str(tmp_path / "cache"))
    files = demo_files("pattern")
    assert files.image.is_file() and files.image.parent == tmp_path / "cache" / "demos"
    assert read_image(files.image).shape == (480, 640, 4)


def test_unknown_demo():
    with pytest.raises(InputError, match="unknown demo 'x'; choose one of starfish, character, pattern"):
        demo_files("x")


@pytest.mark.parametrize(
    "content, message",
    [
        ({"moves": [{"at": 0, "point": 1}]}, r'moves\[0\]: expected an object with "at", "point", "to"'),
        ({"moves": [{"at": 0, "point": 30, "to": [1, 2]}]}, r"point must be a control point index 0..19"),
        (
            {
                "moves": [
                    {"at": 0, "duration": 2, "point": 1, "to": [1, 2]},
                    {"at": 1, "point": 2, "to": [1, 2]},
                ]
            },
            r"moves\[1\]: moves must not overlap",
        ),
        ({"moves": [{"at": 0, "point": 1, "to": ["a", 2]}]}, r"must be numbers"),
        (
            {"moves": [{"at": 0, "point": 1, "to": [1, 2], "fold_free": 1}]},
            r"fold_free must be true or false",
        ),
        ([1, 2], r"moves\[0\]"),
        ({"steps": []}, r'expected \{"moves": \[...\]\}'),
    ],
)
def test_bad_scripts(tmp_path, content, message):
    path = tmp_path / "script.json"
    path.write_text(json.dumps(content))
    with pytest.raises(InputError, match=message):
        read_script(path, 20)


def test_player_turns_moves_into_mouse_events():
    player = ScriptPlayer([Move(1.0, 2.0, 3, (10.0, 0.0)), Move(3.5, 1.0, 1, (0.0, 5.0))])
    positions = {3: np.array([0.0, 0.0]), 1: np.array([1.0, 1.0])}

    def events(time):
        return player.events(time, positions.__getitem__, lambda p: 2.0 * np.asarray(p))

    assert events(0.5) == []
    first = events(1.0)
    assert [e[0] for e in first] == ["press", "move"] and first[0][1:] == (0.0, 0.0)
    middle = events(2.0)[0]
    assert middle[0] == "move" and middle[1:] == pytest.approx((10.0, 0.0))  # eased: halfway at half time
    end = events(3.2)
    assert [e[0] for e in end] == ["move", "release"] and end[-1][1:] == pytest.approx((20.0, 0.0))
    later = events(10.0)
    assert [e[0] for e in later] == ["press", "move", "release"] and later[0][1:] == (2.0, 2.0)
    assert player.finished and player.duration == 4.5


def test_a_move_that_sets_fold_free_says_so_before_its_press(tmp_path):
    path = tmp_path / "script.json"
    moves = [{"at": 0, "point": 1, "to": [1, 2], "fold_free": True}, {"at": 2, "point": 1, "to": [3, 4]}]
    path.write_text(json.dumps({"moves": moves}))
    read = read_script(path, 20)
    assert [move.fold_free for move in read] == [True, None]
    player = ScriptPlayer(read)
    first = player.events(0.5, lambda index: np.zeros(2), lambda p: np.asarray(p))
    assert [e[0] for e in first] == ["fold_free", "press", "move"] and first[0][1] is True
    second = player.events(5.0, lambda index: np.zeros(2), lambda p: np.asarray(p))
    assert [e[0] for e in second] == ["move", "release", "press", "move", "release"]


@pytest.mark.parametrize("name", list(DEMOS))
def test_demo_sessions_hold_their_scripts_as_keyframes(name):
    from app.io.session import read_session

    files = demo_files(name)
    cage = read_cage(files.cage)
    moves = read_script(files.script, len(cage))
    keyframes = demos.demo_keyframes(files)
    assert keyframes == demos.script_keyframes(cage, moves)
    assert len(keyframes) == len(moves) + 2
    np.testing.assert_array_equal(keyframes[0].target, cage)
    np.testing.assert_array_equal(keyframes[-1].target, cage)  # back at the start: it loops
    for before, after, move in zip(keyframes, keyframes[1:], moves, strict=False):
        assert after.time == move.at + move.duration
        assert np.flatnonzero(np.any(after.target != before.target, axis=1)).tolist() == [move.point]
        np.testing.assert_array_equal(after.target[move.point], move.to)
    session = read_session(files.session)
    assert session.image.resolve() == files.image.resolve()
    np.testing.assert_array_equal(session.cage, cage)


def test_export_of_a_demo_is_proposed_in_the_current_folder_not_in_the_package(tmp_path, monkeypatch):
    from app.viewer.demos import demo_files, is_demo_file
    from app.viewer.exports import default_export_path

    monkeypatch.chdir(tmp_path)
    demo = demo_files("starfish").image
    assert is_demo_file(demo) and default_export_path(demo) == tmp_path / "starfish-warped.png"
    photo = tmp_path / "photos" / "cat.png"
    photo.parent.mkdir()
    photo.write_bytes(b"")
    assert not is_demo_file(photo) and default_export_path(photo) == photo.with_name("cat-warped.png")
    photo.with_name("cat-warped.png").write_bytes(b"")
    assert default_export_path(photo) == photo.with_name("cat-warped-2.png")  # never over a file
