"""The real window as a daily tool (issue 50), under Xvfb: the status line above every panel section
at small sizes, undo and redo that say what they did, times on the frame grid, SVG cages."""

from __future__ import annotations

import os
import re
import time

import numpy as np
import pytest
from support.paths import ROOT
from support.viewer_harness import (
    STARFISH_CAGE,
    ViewerProcess,
    drag_point,
    save_png,
    screenshot,
    starfish_session,
    start_xvfb,
    viewer_environment,
    wait_for_session,
    window_pixel,
    xdotool,
)

from app.io.files import read_cage_file
from app.io.svg_cages import svg_text

pytestmark = pytest.mark.slow

CAGE = STARFISH_CAGE
VIEW = {"scale": 1.0, "offset": [320.0, 40.0]}


def last_spot(viewer: ViewerProcess, name: str) -> list[float]:
    line = [line for line in viewer.lines if line.startswith(f"spot {name}=")][-1]
    return [float(v) for v in line.split("=")[1].split(",")]


def settled(viewer: ViewerProcess, seconds: float = 1.0) -> list[str]:
    """Every line the viewer said so far, after `seconds` more of them."""
    deadline = time.monotonic() + seconds
    while (left := deadline - time.monotonic()) > 0:
        try:
            viewer.wait_for("", left)  # whatever is said meanwhile goes into `lines`
        except AssertionError:
            break
    return viewer.lines


def panel_above_status(viewer: ViewerProcess) -> tuple[float, float]:
    """(the panel's bottom, the status line's top), window pixels, as announced once the layout
    has settled."""
    settled(viewer)
    return last_spot(viewer, "panel")[0], last_spot(viewer, "status")[0]


@pytest.mark.parametrize("size", [(1024, 600), (1366, 768)])
def test_no_panel_section_covers_the_status_line(size, tmp_path):
    """Every section open, and then a status message longer than the window is wide (a fitted SVG
    cage opened through the typed path): the panel ends above the status line, which is drawn."""
    server, display = start_xvfb(size)
    session = tmp_path / "s.json"
    starfish_session(session, VIEW)
    circle = tmp_path / "a-circle-drawn-in-another-program-with-a-long-name.svg"
    k = 0.5522847498 * 120
    circle.write_text(
        '<svg xmlns="http://www.w3.org/2000/svg"><path d="M 520 250 '
        f"C 520 {250 + k} {400 + k} 370 400 370 C {400 - k} 370 280 {250 + k} 280 250 "
        f'C 280 {250 - k} {400 - k} 130 400 130 C {400 + k} 130 520 {250 - k} 520 250 Z"/></svg>'
    )
    no_programs = tmp_path / "empty-bin"
    no_programs.mkdir()
    env = {**viewer_environment(display, tmp_path), "PATH": str(no_programs)}
    viewer = ViewerProcess(["view", "--session", str(session)], env, ROOT, window_size=size)
    try:
        window = viewer.wait_for("ready window=", 30).split("=")[1]
        viewer.wait_for("basis ", 60)
        xdotool(display, "windowfocus", "--sync", window)
        panel_above_status(viewer)  # the layout after the first basis (no progress bar)
        for section in ("Animation", "Show"):  # the lower first: opening it moves nothing above
            x, y = last_spot(viewer, section)
            xdotool(display, "mousemove", "--window", window, f"{x:.0f}", f"{y:.0f}", "click", "1")
            time.sleep(0.4)
        bottom, top = panel_above_status(viewer)
        assert bottom <= top <= size[1] - 20, (bottom, top)
        xdotool(display, "key", "ctrl+o")
        viewer.wait_for("text input on", 10)
        xdotool(display, "key", "ctrl+a")
        time.sleep(0.3)
        xdotool(display, "type", "--delay", "5", str(circle))
        xdotool(display, "key", "Return")
        said = viewer.wait_for("status said ", 20)
        assert "the path is not a quadratic B-spline; fitted" in said, said
        bottom, wrapped_top = panel_above_status(viewer)
        assert wrapped_top < top and bottom <= wrapped_top, (bottom, wrapped_top, top)
        pixels = screenshot(display)
        save_png(tmp_path / "status.png", pixels)
        strip = pixels[size[1] - 24 : size[1] - 4, 0:500].astype(int)
        assert (strip.min(axis=-1) > 170).sum() > 100  # the status line's light text on its dark bar
        xdotool(display, "key", "ctrl+q")
        code, stderr = viewer.finish()
        assert code == 0, stderr
    finally:
        viewer.kill()
        server.terminate()
        server.wait(timeout=10)


@pytest.fixture(scope="module")
def display():
    server, name = start_xvfb((1280, 1024))
    yield name
    server.terminate()
    server.wait(timeout=10)


def test_undo_and_redo_say_what_they_did_and_redo_reuses_the_proof(display, tmp_path):
    session = tmp_path / "undo.json"
    starfish_session(session, VIEW)
    viewer = ViewerProcess(["view", "--session", str(session)], viewer_environment(display, tmp_path), ROOT)
    try:
        window = viewer.wait_for("ready window=", 30).split("=")[1]
        viewer.wait_for("basis ", 60)
        viewer.wait_for("check fold_free=False", 60)
        xdotool(display, "windowfocus", "--sync", window)
        xdotool(display, "key", "b")
        viewer.wait_for("check fold_free=True", 90)
        xdotool(display, "key", "ctrl+z")
        assert viewer.wait_for("status said ", 10) == "status said undone: fold-free on"
        lines = settled(viewer)
        assert [line for line in lines if line.startswith("fold-free ")][-1] == "fold-free off folded=0"
        checks = [line for line in lines if line.startswith("check ")]
        assert checks[-1] == "check reused fold_free=False"  # the plain map's proof, kept
        xdotool(display, "key", "ctrl+shift+z")
        assert viewer.wait_for("status said ", 10) == "status said redone: fold-free on"
        lines = settled(viewer)
        assert [line for line in lines if line.startswith("fold-free ")][-1] == "fold-free drawn folded=0"
        checks = [line for line in lines if line.startswith("check ")]
        assert checks[-2:] == ["check reused fold_free=False", "check reused fold_free=True"]  # no new proof
        wait_for_session(session, lambda c, t, v: v.get("fold_free") is True)
        xdotool(display, "key", "ctrl+q")
        code, stderr = viewer.finish()
        assert code == 0, stderr
    finally:
        viewer.kill()


def test_a_pause_and_the_key_of_a_drag_sit_on_the_frame_grid(display, tmp_path):
    session = tmp_path / "frames.json"
    starfish_session(session, VIEW, keyframes=(0.0, 2.0))
    viewer = ViewerProcess(["view", "--session", str(session)], viewer_environment(display, tmp_path), ROOT)
    try:
        window = viewer.wait_for("ready window=", 30).split("=")[1]
        viewer.wait_for("basis ", 60)
        xdotool(display, "windowfocus", "--sync", window)
        xdotool(display, "key", "space")
        viewer.wait_for("playback started", 10)
        time.sleep(0.77)
        xdotool(display, "key", "space")
        paused = re.fullmatch(
            r"status said paused at ([\d.]+) s \(frame (\d+)\)", viewer.wait_for("status said paused", 10)
        )
        assert paused and 0 < int(paused[2]) < 60, viewer.lines[-3:]
        frame = int(paused[2])
        drag_point(display, window, window_pixel(VIEW, CAGE[12]), np.array([-40.0, 30.0]))
        _, _, saved = wait_for_session(session, lambda c, t, v: len(v["keyframes"]) == 3)
        times = [k["time"] for k in saved["keyframes"]]
        assert times == [0.0, frame / 30, 2.0]
        assert saved["viewer"]["fps"] == 30.0
        xdotool(display, "key", "ctrl+q")
        code, stderr = viewer.finish()
        assert code == 0, stderr
    finally:
        viewer.kill()


def test_without_a_dialog_program_the_window_lists_the_files_and_a_double_click_opens_one(display, tmp_path):
    """Ctrl+O on a machine without zenity or kdialog: the typed-path field lists the folder, says
    why, and a double click on an SVG cage in it opens that cage (exactly: a Q/T chain)."""
    session = tmp_path / "browse.json"
    starfish_session(session, VIEW)
    folder = tmp_path / "pick"
    folder.mkdir()
    moved = CAGE + [3.5, -2.25]
    (folder / "cage.svg").write_text(svg_text(moved, 640, 480))
    no_programs = tmp_path / "empty-bin"
    no_programs.mkdir()
    env = {**viewer_environment(display, tmp_path), "PATH": str(no_programs)}
    viewer = ViewerProcess(["view", "--session", str(session)], env, ROOT)
    try:
        window = viewer.wait_for("ready window=", 30).split("=")[1]
        viewer.wait_for("basis ", 60)
        xdotool(display, "windowfocus", "--sync", window)
        xdotool(display, "key", "ctrl+o")
        viewer.wait_for("text input on", 10)
        xdotool(display, "key", "ctrl+a")
        time.sleep(0.3)
        xdotool(display, "type", "--delay", "5", f"{folder}{os.sep}")
        settled(viewer)
        first, pitch = last_spot(viewer, "files")
        # The list: "..", then cage.svg; a double click on the file opens it.
        xdotool(display, "mousemove", "--window", window, "640", f"{first + pitch:.0f}")
        time.sleep(0.2)
        xdotool(display, "click", "--repeat", "2", "--delay", "80", "1")
        said = viewer.wait_for("status said cage from", 10)
        assert said == f"status said cage from {folder / 'cage.svg'}"
        cage, target, _ = wait_for_session(session, lambda c, t, v: np.allclose(c, moved, atol=1e-9))
        np.testing.assert_array_equal(cage, target)
        pixels = screenshot(display)
        save_png(tmp_path / "browsed.png", pixels)
        xdotool(display, "key", "ctrl+q")
        code, stderr = viewer.finish()
        assert code == 0, stderr
    finally:
        viewer.kill()


def test_save_target_writes_the_exact_chain_that_warp_reads_back(display, tmp_path):
    """Save target... without a dialog program: the typed path in the window, an SVG written over the
    image's size that reads back (as --target does) to the session's target exactly."""
    session = tmp_path / "save.json"
    starfish_session(session, VIEW)
    no_programs = tmp_path / "empty-bin"
    no_programs.mkdir()
    env = {**viewer_environment(display, tmp_path), "PATH": str(no_programs)}
    viewer = ViewerProcess(["view", "--session", str(session)], env, ROOT)
    try:
        window = viewer.wait_for("ready window=", 30).split("=")[1]
        viewer.wait_for("basis ", 60)
        xdotool(display, "windowfocus", "--sync", window)
        drag_point(display, window, window_pixel(VIEW, CAGE[4]), np.array([35.0, -25.0]))
        _, target, _ = wait_for_session(session, lambda c, t, v: not np.array_equal(c, t))
        settled(viewer)
        x, y = last_spot(viewer, "save target")
        xdotool(display, "mousemove", "--window", window, f"{x:.0f}", f"{y:.0f}", "click", "1")
        viewer.wait_for("text input on", 10)
        xdotool(display, "key", "ctrl+a")
        time.sleep(0.3)
        saved = tmp_path / "target.svg"
        xdotool(display, "type", "--delay", "5", str(saved))
        xdotool(display, "key", "Return")
        assert viewer.wait_for("status said ", 10) == f"status said saved the target to {saved}"
        assert 'width="640" height="480"' in saved.read_text()
        points, remark = read_cage_file(saved)
        assert remark is None and np.abs(points - target).max() <= 1e-9
        xdotool(display, "key", "ctrl+q")
        code, stderr = viewer.finish()
        assert code == 0, stderr
    finally:
        viewer.kill()
