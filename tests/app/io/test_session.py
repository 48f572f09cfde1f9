"""Tests of app.io.session: the session model, its checks, reading old files, round trips."""

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from app.io.files import InputError
from app.io.session import (
    Animation,
    History,
    HistoryStep,
    KernelChoice,
    OutputChoice,
    Pin,
    Session,
    ViewerSettings,
    existing_image,
    read_session,
    session_json,
    write_session,
)
from app.render.viewport import View
from app.warp.keyframes import Keyframe
from core import KERNEL_TABLE

SQUARE = [[10, 10], [50, 10], [50, 40], [10, 40]]
TRIANGLE = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])

#: A session as the first versions wrote it: the five required keys only, and a ``viewer`` with
#: the settings of then (no ``time``, ``loop``), a ``history`` whose steps have no keyframes,
#: interpolation, parameterization nor fold_free.
OLD_SESSION = """{
  "viewer": {"mode": "deform", "content": "image", "show_folds": true, "power": 3.0, "shift": "integral"},
  "history": {
    "undo": [{"cage": [[10, 10], [50, 10], [50, 40], [10, 40]],
              "target": [[10, 10], [50, 10], [50, 40], [10, 40]],
              "kernel": "power", "power": 3.0, "shift": "integral"}],
    "redo": []
  },
  "image": "picture.png",
  "cage": {"control_points": [[10, 10], [50, 10], [50, 40], [10, 40]]},
  "target": {"control_points": [[12, 10], [50, 10], [50, 40], [10, 40]]},
  "kernel": "mean-value",
  "view": {"scale": 1.5, "offset": [3, 4]}
}
"""


def write(path, text):
    path.write_text(text)
    return path


def session_value(**changes):
    value = {
        "image": "picture.png",
        "cage": {"control_points": SQUARE},
        "target": {"control_points": SQUARE},
        "kernel": "harmonic-like",
        "view": {"scale": 1.5, "offset": [3, 4]},
        "comment": "kept",
    }
    value.update(changes)
    return value


def read_value(tmp_path, **changes) -> Session:
    return read_session(write(tmp_path / "s.json", json.dumps(session_value(**changes))))


def test_an_old_session_reads_with_the_defaults_of_its_missing_keys(tmp_path):
    session = read_session(write(tmp_path / "old.json", OLD_SESSION))
    assert session.image == tmp_path / "picture.png" and session.view == View(1.5, (3.0, 4.0))
    assert session.kernel == KernelChoice("mean-value", {}, "natural")
    assert session.max_edge is None and session.fold_free is False and session.pins == ()
    assert session.max_distortion is None and session.output == OutputChoice("transparent", "source")
    assert session.animation == Animation((), "catmull-rom") and session.extra == {}
    assert session.viewer == ViewerSettings(
        mode="deform", content="image", show_folds=True, power=3.0, shift="integral"
    )
    (step,) = session.history.undo
    assert step.kernel == "power" and (step.power, step.shift) == (3.0, "integral") and step.keyframes == ()
    assert (step.interpolation, step.parameterization, step.fold_free) == ("catmull-rom", "natural", False)
    assert session.history.redo == () and session.history.problem == ""


def test_a_round_trip_keeps_unknown_keys_and_the_relative_image(tmp_path):
    session = read_value(tmp_path, fill="#FF0000", pins=[{"at": [1, 2], "to": [3.5, 4]}], max_distortion=2)
    assert session.image == tmp_path / "picture.png"
    assert session.extra == {"comment": "kept"} and session.output.fill == "#ff0000"
    write_session(tmp_path / "copy.json", session)
    written = json.loads((tmp_path / "copy.json").read_text())
    assert written["image"] == "picture.png" and written["comment"] == "kept"
    assert written["pins"] == [{"at": [1.0, 2.0], "to": [3.5, 4.0]}] and written["max_distortion"] == 2.0
    again = read_session(tmp_path / "copy.json")
    assert session_json(again) == session_json(session)
    np.testing.assert_array_equal(again.cage, np.array(SQUARE, float))


def test_defaults_that_older_versions_did_not_write_stay_out_of_the_file():
    written = session_json(Session(Path("a.png"), TRIANGLE, TRIANGLE))
    assert set(written) == {"cage", "target", "kernel", "view", "parameterization"} | {
        "outside", "canvas", "keyframes", "interpolation",
    }  # fmt: skip
    assert written["kernel"] == "poisson" and written["view"] == {"scale": 1.0, "offset": [0.0, 0.0]}


def test_a_full_session_survives_a_round_trip(tmp_path):
    keyframes = (Keyframe(0.0, TRIANGLE), Keyframe(1.5, TRIANGLE + 1))
    step = HistoryStep(
        TRIANGLE, TRIANGLE + 2, "poisson", 4.0, "mean", keyframes, "linear", "arc-length", True
    )
    session = Session(
        tmp_path / "a.png",
        TRIANGLE,
        TRIANGLE + 1,
        KernelChoice("power", {"power": 2.5, "shift": "mean"}, "arc-length"),
        View(2.0, (1.0, -1.0)),
        max_edge=3.0,
        fold_free=True,
        pins=(Pin((0.5, 0.25), (0.75, 0.5)),),
        max_distortion=4.0,
        output=OutputChoice("original", "grow", "inpaint", "#0000ff"),
        animation=Animation(keyframes, "linear"),
        viewer=ViewerSettings(mode="cage", selected=2, time=0.5, loop=False),
        history=History((step,), ()),
        extra={"note": [1, 2]},
    )
    write_session(tmp_path / "s.json", session)
    again = read_session(tmp_path / "s.json")
    assert session_json(again) == session_json(session)
    assert again.history.undo[0].fold_free is True and again.output.background_rgba == (0.0, 0.0, 1.0, 1.0)


def test_kernel_parameters_are_checked_against_cores_kernel_table():
    takes = [name for name, kernel in KERNEL_TABLE.items() if kernel.parameters]
    assert "power" in takes  # what the session checks below
    assert KernelChoice("power", {"power": 2, "shift": "mean"}).params == {"power": 2, "shift": "mean"}
    for kernel, params, message in [
        ("power", {"power": -1}, "kernel_params: power must be a finite number > 0"),
        ("power", {"shift": "up"}, "kernel_params: shift must be one of none, integral, mean"),
        ("power", {"power": "3"}, "kernel_params power must be a number or a word, got '3'"),
        ("power", {"shift": True}, "kernel_params shift must be a number or a word, got True"),
        ("power", {"gamma": 1}, r"unknown kernel parameter\(s\) gamma \(power takes power, shift\)"),
        ("mean-value", {"power": 2}, "kernel 'mean-value' takes no parameters, but kernel_params has power"),
        ("bogus", {}, "unknown kernel 'bogus'"),
    ]:
        with pytest.raises(ValueError, match=message):
            KernelChoice(kernel, params)
    with pytest.raises(ValueError, match='"parameterization" must be one of natural, arc-length'):
        KernelChoice("power", {}, "chord")


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"image": 3}, r'"image" must be a file path'),
        ({"kernel": "bogus"}, r"unknown kernel 'bogus'; choose one of .*harmonic-like"),
        ({"target": {"control_points": SQUARE[:3]}}, r"target has 3 control points but cage has 4"),
        ({"cage": {"control_points": [[0, 0], [1, 1]]}}, r"s.json: cage: control_points needs at least 3"),
        ({"view": {"scale": 0, "offset": [0, 0]}}, r"view scale must be a finite number > 0"),
        ({"view": {"scale": 1, "offset": [0]}}, r"view offset must be two finite numbers"),
        ({"view": [1, 2]}, r'"view" must be an object'),
        ({"kernel_params": []}, r'"kernel_params" must be an object, got a list'),
        ({"kernel_params": {"power": 2}}, "kernel 'harmonic-like' takes no parameters"),
        ({"mesh": {"max_edge": "big"}}, "s.json: mesh max_edge must be a number > 0, got 'big'"),
        ({"mesh": {"max_edge": -2}}, "s.json: mesh max_edge must be a number > 0, got -2"),
        ({"mesh": 3}, r's.json: "mesh" must be an object'),
        ({"fold_free": "yes"}, r's.json: "fold_free" must be true or false'),
        ({"outside": "mirror"}, r'"outside" must be one of transparent, original'),
        ({"canvas": "page"}, r'"canvas" must be one of source, grow'),
        ({"fill": "sepia"}, r's.json: "fill": must be none, transparent, inpaint or a colour'),
        ({"background": 7}, r'"background" must be a colour or "none", got 7'),
        ({"background": "#12"}, r's.json: "background": '),
        ({"parameterization": "chord"}, r'"parameterization" must be one of natural, arc-length'),
        ({"keyframes": {}}, '"keyframes" must be a list'),
        ({"keyframes": [{"time": 0}]}, r'keyframes\[0\]: expected an object with "time" and "target"'),
        ({"keyframes": [{"time": -1, "target": {"control_points": SQUARE}}]}, "time must be within"),
        ({"keyframes": [{"time": 0, "target": {"control_points": SQUARE[:3]}}]}, "target has 3 control"),
        ({"interpolation": "spline"}, '"interpolation" must be one of'),
        ({"pins": {}}, r'"pins" must be a list, got an object'),
        ({"pins": [{"at": [1, 2]}]}, r'pins\[0\]: expected an object with "at" and "to"'),
        ({"pins": [{"at": [1, 2], "to": [1e999, 0]}]}, r'pins\[0\]: "to" must be two finite numbers'),
        ({"pins": [{"at": [1], "to": [1, 0]}]}, r'pins\[0\]: "at" must be two finite numbers'),
        ({"max_distortion": 0.5}, r'"max_distortion" must be a number >= 1, got 0.5'),
        ({"max_distortion": "2"}, r'"max_distortion" must be a finite number'),
    ],
)
def test_bad_sessions_are_one_line_naming_the_file_and_the_key(tmp_path, changes, message):
    with pytest.raises(InputError, match=message):
        read_value(tmp_path, **changes)


def test_missing_keys_are_named(tmp_path):
    value = session_value()
    del value["target"], value["view"]
    with pytest.raises(InputError, match=r"s.json: missing key\(s\) target, view"):
        read_session(write(tmp_path / "s.json", json.dumps(value)))


def test_the_model_refuses_what_the_file_would_refuse():
    for changes, message in [
        ({"target": TRIANGLE[:2]}, "target has 2 control points but cage has 3"),
        ({"max_distortion": math.nan}, "max_distortion"),
        ({"max_edge": 0.0}, "max_edge must be a number > 0"),
        ({"pins": (Pin((0, 0), (1, 1)),), "extra": {"pins": []}}, "extra holds key"),
        ({"animation": Animation((Keyframe(0.0, SQUARE),))}, r"keyframes\[0\]: target has 4 control points"),
    ]:
        with pytest.raises(ValueError, match=message):
            Session(**{"image": "a.png", "cage": TRIANGLE, "target": TRIANGLE, **changes})


def test_viewer_settings_of_another_type_read_as_absent(tmp_path):
    settings = read_value(tmp_path, viewer={"mode": 3, "selected": True, "time": "now", "loop": True}).viewer
    assert settings == ViewerSettings(loop=True)
    assert read_value(tmp_path, viewer=[1]).viewer == ViewerSettings()


def test_an_unreadable_history_loses_the_steps_not_the_session(tmp_path):
    history = read_value(tmp_path, history={"undo": [{"cage": [[0, 0]]}]}).history
    assert history.undo == () and history.problem == "undo[0]: missing 'target'"
    step = {**json.loads(OLD_SESSION)["history"]["undo"][0], "kernel": "x"}
    history = read_value(tmp_path, history={"redo": [step]}).history
    assert history.redo == () and history.problem == "redo[0]: unknown kernel 'x'"
    assert (
        read_value(tmp_path, history={"undo": [{**step, "kernel": "poisson", "fold_free": 1}]})
        .history.undo[0]
        .fold_free
        is False
    )  # only true is true, as the viewer always read it


def test_the_image_is_looked_for_beside_the_session_file(tmp_path):
    session = read_value(tmp_path)
    with pytest.raises(
        InputError, match=r"its \"image\" 'picture.png' is .*picture.png, which does not exist"
    ):
        existing_image(session, tmp_path / "s.json")
    (tmp_path / "picture.png").write_bytes(b"")
    assert existing_image(session, tmp_path / "s.json") == tmp_path / "picture.png"


def test_a_history_step_keeps_its_output_choices_and_an_older_step_has_none(tmp_path):
    # A step written with its output choices reads back with them; a step of an older session,
    # without them, reads as None (the viewer gives it the session's).
    from app.io.session import HistoryStep, OutputChoice, read_session, session_json, write_session

    path = tmp_path / "s.json"
    cage = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]]
    value = {"image": "p.png", "cage": {"control_points": cage}, "target": {"control_points": cage}}
    value.update(kernel="poisson", view={"scale": 1.0, "offset": [0.0, 0.0]})
    path.write_text(json.dumps(value))
    step = HistoryStep(cage, cage, "poisson", 1.0, "none", output=OutputChoice("original", fill="inpaint"))
    older = HistoryStep(cage, cage, "poisson", 1.0, "none")
    session = dataclasses.replace(read_session(path), history=History(undo=(step, older)))
    written = session_json(session)["history"]["undo"]
    assert written[0]["fill"] == "inpaint" and "fill" not in written[1]
    write_session(path, session)
    undo = read_session(path).history.undo
    assert undo[0].output == OutputChoice("original", fill="inpaint") and undo[1].output is None
