"""The boundary parameterization (natural or arc length, Fig. 12) through the app: the command
line (warp, compare, view), the viewer's state, precompute and panel command, the session file."""

from __future__ import annotations

import json
import os
import re

import numpy as np
import pytest
from support.commands import CAGE, files, private_cache, run_main, warp_argv  # noqa: F401 (fixtures)

from app.io.files import read_image
from app.viewer import documents as sessions
from app.viewer.commands import command as run_command
from app.viewer.demos import demo_files
from app.viewer.precompute import basis_key, make_request
from app.viewer.state import AppState, Document, History


@pytest.fixture(autouse=True)
def state_directory(tmp_path, monkeypatch):
    monkeypatch.setenv("TRANSFINITE_STATE_DIR", str(tmp_path / "state"))


# -- command line -----------------------------------------------------------------------------


def warp(files, capfd, output, *argv):  # noqa: F811 (the fixture, passed on)
    code, _, err = run_main([*argv, "--output", files / output], capfd)
    assert code == 0, err
    return read_image(files / output)


def test_warp_in_arc_length_differs_and_a_session_carries_it(files, capfd):  # noqa: F811
    # Not an affine target: every kernel reproduces those exactly (linear precision).
    target = np.array(CAGE, dtype=float)
    target[3] += [12.0, 9.0]
    (files / "target.json").write_text(json.dumps({"control_points": target.tolist()}))
    session = json.loads((files / "session.json").read_text())
    session["target"] = {"control_points": target.tolist()}
    (files / "session.json").write_text(json.dumps(session))
    explicit = [*warp_argv(files, **{"--output": None}), "--kernel", "harmonic-like"]
    natural = warp(files, capfd, "natural.png", *explicit)
    arc = warp(files, capfd, "arc.png", *explicit, "--parameterization", "arc-length")
    assert natural.shape == arc.shape and not np.array_equal(natural, arc)
    # The session (kernel harmonic-like) names the parameterization; without the key, natural.
    assert "parameterization" not in session
    from_session = ["warp", "--session", files / "session.json"]
    assert np.array_equal(warp(files, capfd, "s.png", *from_session), natural)
    assert np.array_equal(
        warp(files, capfd, "s-arc.png", *from_session, "--parameterization", "arc-length"), arc
    )
    (files / "arc.json").write_text(json.dumps(session | {"parameterization": "arc-length"}))
    assert np.array_equal(warp(files, capfd, "a.png", "warp", "--session", files / "arc.json"), arc)


@pytest.mark.parametrize("kernel", ["poisson", "harmonic", "cauchy-green"])
def test_warp_refuses_arc_length_for_the_geometric_kernels_in_one_line(files, capfd, kernel):  # noqa: F811
    argv = [*warp_argv(files), "--kernel", kernel, "--parameterization", "arc-length"]
    code, _, err = run_main(argv, capfd)
    assert code == 2 and err.count("\n") == 1
    assert err.startswith(f"error: --parameterization arc-length: kernel {kernel!r} does not depend")
    assert not (files / "out.png").exists()
    # A session's arc length does not bind a mesh kernel chosen on the command line.
    session = json.loads((files / "session.json").read_text()) | {"parameterization": "arc-length"}
    (files / "arc.json").write_text(json.dumps(session))
    argv = ["warp", "--session", files / "arc.json", "--output", files / "h.png", "--kernel", "harmonic"]
    assert run_main(argv, capfd)[0] == 0


def test_a_bad_parameterization_in_a_session_is_one_line(files, capfd):  # noqa: F811
    session = json.loads((files / "session.json").read_text()) | {"parameterization": "chord"}
    (files / "bad.json").write_text(json.dumps(session))
    code, _, err = run_main(["warp", "--session", files / "bad.json", "--output", files / "b.png"], capfd)
    assert code == 2 and err.strip() == (
        f"error: {files / 'bad.json'}: \"parameterization\" must be one of natural, arc-length, got 'chord'"
    )
    code, _, err = run_main([*warp_argv(files), "--parameterization", "chord"], capfd)
    assert code == 2 and "invalid choice: 'chord'" in err


@pytest.mark.parametrize("parameterization", ["arc-length", "both"])
def test_compare_shows_the_arc_length_kernels(files, capfd, parameterization):  # noqa: F811
    argv = ["compare", "--cage", files / "cage.json", "--output", files / "fig.png", "--max-edge", "8"]
    argv += ["--kernel", "harmonic-like", "--kernel", "pgw", "--parameterization", parameterization]
    code, out, err = run_main(argv, capfd)
    assert code == 0, err
    rows = {
        match[1]: match.groups()[1:]
        for match in (
            re.match(r"(.+?)\s+([\d.]+)\s+([\d.]+)\s+[\d.]+s$", line) for line in out.splitlines()[1:]
        )
    }
    expected = {"harmonic", "pgw", "harmonic-like, arc length"} | (
        {"harmonic-like"} if parameterization == "both" else set()
    )
    assert set(rows) == expected
    rms = float(rows["harmonic-like, arc length"][0])  # RMS distance to the harmonic interpolant
    assert 0 < rms < 0.3
    if parameterization == "both":
        assert float(rows["harmonic-like"][0]) != rms
    figure = read_image(files / "fig.png")
    assert figure.shape[1] > 3 * 300 and (figure[..., 3] == 255).all()


# -- viewer -----------------------------------------------------------------------------------


def starfish_state(tmp_path):
    demo = demo_files("starfish")
    document = sessions.open_document(demo.image, demo.cage, tmp_path / "s.json")
    snapshot = document.snapshot.replace(kernel="harmonic-like")
    return AppState(Document(History(snapshot), snapshot, document.image, tmp_path / "s.json"))


def test_the_panel_command_is_one_undoable_step_and_changes_the_precompute(tmp_path):
    state = starfish_state(tmp_path)
    natural = state.document.live
    assert run_command(state, "parameterization", "arc-length")
    arc = state.document.live
    assert arc.parameterization == "arc-length" and state.document.history.undo_steps[-1] == natural
    assert make_request(arc, 4.0).params == {"parameterization": "arc-length"}
    assert basis_key(arc, 4.0) != basis_key(natural, 4.0)
    # The mesh-based kernels do not depend on it: the same basis functions, no new precompute.
    assert basis_key(arc.replace(kernel="harmonic"), 4.0) == basis_key(
        natural.replace(kernel="harmonic"), 4.0
    )
    assert make_request(arc.replace(kernel="harmonic"), 4.0).params == {}
    run_command(state, "parameterization", "chord")
    assert state.document.live == arc and "unknown parameterization" in state.status.message
    run_command(state, "undo", None)
    assert state.document.live == natural


def test_the_session_round_trip_and_older_sessions(tmp_path):
    state = starfish_state(tmp_path)
    run_command(state, "parameterization", "arc-length")
    sessions.save(state, None)
    stored = json.loads(state.document.session_path.read_text())
    assert stored["parameterization"] == "arc-length"
    assert stored["history"]["undo"][-1]["parameterization"] == "natural"
    restored = sessions.restore(state.document.session_path)
    assert restored.snapshot == state.document.live and restored.snapshot.parameterization == "arc-length"
    assert restored.undo[-1].parameterization == "natural"
    # A session of the version before the choice: no key anywhere, natural everywhere.
    del stored["parameterization"]
    for step in stored["history"]["undo"]:
        del step["parameterization"]
    state.document.session_path.write_text(json.dumps(stored))
    older = sessions.restore(state.document.session_path)
    assert older.snapshot.parameterization == "natural" and older.undo[-1].parameterization == "natural"
    assert older.snapshot == state.document.live.replace(parameterization="natural")


def test_view_starts_with_the_command_lines_parameterization(tmp_path, monkeypatch):
    from app.commands import cli
    from app.viewer import window

    opened = {}
    monkeypatch.setattr(
        window, "run", lambda document, options: opened.setdefault("document", document) and 0
    )
    demo = demo_files("starfish")
    path = tmp_path / "v.json"
    cli.main(["view", str(demo.image), "--cage", str(demo.cage), "--session", str(path)])
    assert opened.pop("document").snapshot.parameterization == "natural"
    cli.main(["view", "--session", str(path), "--parameterization", "arc-length"])
    document = opened.pop("document")
    assert document.snapshot.parameterization == "arc-length"
    assert document.undo[-1].parameterization == "natural"  # the session's state, a Ctrl+Z away


@pytest.mark.slow
def test_the_real_window_switches_to_arc_length_and_back(tmp_path):
    # The panel's choice in the real window (Xvfb, llvmpipe): a click on "arc length" recomputes
    # the basis, changes the picture and is saved; Ctrl+Z goes back.  The session holds a point
    # kernel and a strong deformation, so nothing depends on the timing of a mouse drag.
    from support.paths import ROOT
    from support.viewer_harness import (
        ViewerProcess,
        changed_fraction,
        park_mouse,
        session_points,
        shot,
        start_xvfb,
        wait_for_session,
        xdotool,
    )

    session = tmp_path / "arc.json"
    value = json.loads((ROOT / "assets" / "starfish.session.json").read_text())
    target = np.array(value["cage"]["control_points"], dtype=float)
    target[0] += [150.0, 60.0]  # an arm tip pulled far out
    value.update(image=str(ROOT / "assets" / "starfish.png"), kernel="harmonic-like", keyframes=[])
    value["view"] = {"scale": 1.0, "offset": [450.0, 250.0]}  # all of it right of the panel
    value["target"] = {"control_points": target.tolist()}
    session.write_text(json.dumps(value))
    process, display = start_xvfb()
    env = {
        **os.environ,
        "DISPLAY": display,
        "TRANSFINITE_CACHE_DIR": str(tmp_path / "cache"),
        "TRANSFINITE_STATE_DIR": str(tmp_path / "state"),
    }
    viewer = ViewerProcess(["view", "--session", str(session)], env, ROOT)
    try:
        window = viewer.wait_for("ready window=", 30).split("=")[1]
        arc_button = viewer.wait_for("spot arc-length=").split("=")[1].split(",")
        natural_key = viewer.wait_for("basis key=", 120).split()[1]
        assert session_points(session)[2].get("parameterization", "natural") == "natural"
        park_mouse(display, window)
        natural = shot(display, tmp_path, "parameterization-natural")
        xdotool(display, "mousemove", "--window", window, *arc_button)
        xdotool(display, "click", "1")
        assert viewer.wait_for("basis key=", 120).split()[1] != natural_key  # a new precompute
        wait_for_session(session, lambda c, t, v: v["parameterization"] == "arc-length")
        park_mouse(display, window)
        arc = shot(display, tmp_path, "parameterization-arc-length")
        # Two shots of one state have identical canvases; the new basis moves the pulled arm.
        assert changed_fraction(natural, arc) > 0.001
        xdotool(display, "key", "ctrl+z")
        wait_for_session(session, lambda c, t, v: v["parameterization"] == "natural")
    finally:
        viewer.kill()
        process.terminate()
        process.wait(timeout=10)


def test_quality_takes_the_parameterization_as_a_kernel_parameter():
    from app.io.files import InputError
    from app.studies.quality import KernelChoice, parse_kernel

    choice = parse_kernel("harmonic-like:parameterization=arc-length")
    assert choice == KernelChoice(
        "harmonic-like:parameterization=arc-length", "harmonic-like", {"parameterization": "arc-length"}
    )
    with pytest.raises(InputError, match="unknown parameterization 'chord'"):
        parse_kernel("harmonic-like:parameterization=chord")
    with pytest.raises(InputError, match="does not take parameter"):
        parse_kernel("harmonic-like:shift=mean,parameterization=arc-length")
