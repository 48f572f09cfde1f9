"""The real viewer window under Xvfb, driven by real X input events (xdotool).

One viewer session: start, drag a target control point, check the screen changed
where the arm moved and nowhere else, undo (Ctrl+Z), redo (Ctrl+Shift+Z and
Ctrl+Y), cancel a drag with Esc, export (Ctrl+E) and compare with
``python -m app warp --session``, quit (Ctrl+Q); then reopen the saved session and
check the same picture comes back, and close the window like a window manager.

Xvfb and xdotool are required: without them these tests fail, they never skip.
Screenshots are kept in the test's temporary directory (and under
``$VIEWER_SCREENSHOTS`` when set, for people to look at).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from support.paths import ROOT
from support.viewer_harness import (
    PANEL_RIGHT,
    STATUS_TOP,
    ViewerProcess,
    changed_fraction,
    close_window,
    drag_point,
    park_mouse,
    press_and_move,
    session_points,
    shot,
    wait_for_session,
    wait_until_ended,
    window_pixel,
    xdotool,
)

from app.io.files import read_image
from app.viewer.editing import SAMPLES_PER_SPAN, curve_matrix
from app.viewer.window import IDLE_WAIT

pytestmark = pytest.mark.slow

ASSETS = ROOT / "assets"
COLOUR_BAR_LEFT = 1020  # window pixels: the colour bar of the field views, bottom right


@pytest.fixture(scope="module")
def environment(display, tmp_path_factory):
    folder = tmp_path_factory.mktemp("viewer")
    env = {
        **os.environ,
        "DISPLAY": display,
        "TRANSFINITE_CACHE_DIR": str(folder / "cache"),
        "TRANSFINITE_STATE_DIR": str(folder / "state"),
    }
    return env, folder


def shot_once(display: str, folder: Path, name: str, drawn, seconds: float = 20.0) -> np.ndarray:
    """`shot` again until `drawn(pixels)` holds or `seconds` pass: a loaded machine may draw the frame
    of the last event a few seconds after the session was saved (the caller asserts on the result)."""
    deadline = time.monotonic() + seconds
    pixels = shot(display, folder, name)
    while not drawn(pixels) and time.monotonic() < deadline:
        pixels = shot(display, folder, name)
    return pixels


def box_difference(a: np.ndarray, b: np.ndarray, centre, half: int) -> float:
    x, y = int(round(centre[0])), int(round(centre[1]))
    region = (slice(max(y - half, 0), y + half), slice(max(x - half, 0), x + half))
    return float(np.abs(a[region] - b[region]).mean())


def stats_line(lines: list[str]) -> re.Match:
    for line in lines:
        match = re.fullmatch(
            r"frames=(\d+) median_frame_ms=([\d.]+) p95_frame_ms=([\d.]+) median_drag_frame_ms=([\d.]+) "
            r"fold_free_drag_frames=\d+ max_folded_drawn=\d+ median_fold_free_drag_frame_ms=[\d.]+ "
            r"proven_after_release_ms=(?:\d+|none) median_plain_drag_frame_ms=[\d.]+ "
            r"fold_free_drag_frames_on_target=\d+ max_boundary_lag_px=[\d.]+ "
            r"max_fold_free_drag_frame_ms=[\d.]+",
            line,
        )
        if match:
            return match
    raise AssertionError(f"no stats line in {lines}")


def test_drag_undo_redo_export_quit_and_restore(display, environment):
    env, folder = environment
    session = folder / "session.json"
    exported = folder / "exported.png"
    viewer = ViewerProcess(
        [
            "view",
            str(ASSETS / "starfish.png"),
            "--cage",
            str(ASSETS / "starfish.cage.json"),
            "--session",
            str(session),
            "--export",
            str(exported),
            "--stats",
        ],
        env,
        ROOT,
    )
    try:
        window = viewer.wait_for("ready window=", 30).split("=")[1]
        viewer.wait_for("drawn basis ", 60)  # on screen: the frame with only the cage came before
        cage, target, value = session_points(session)
        view = value["view"]
        assert np.array_equal(cage, target)
        park_mouse(display, window)
        before = shot(display, folder, "1-start")

        # Drag the top arm's tip (control point 0) with real button and motion events.
        start = window_pixel(view, target[0])
        drag = np.array([90.0, 40.0])
        xdotool(display, "mousemove", "--window", window, *(f"{v:.0f}" for v in start))
        time.sleep(0.2)
        xdotool(display, "mousedown", "1")
        for step in np.linspace(0.1, 1.0, 10):
            xdotool(display, "mousemove", "--window", window, *(f"{v:.0f}" for v in start + step * drag))
            time.sleep(0.03)
        xdotool(display, "mouseup", "1")
        viewer.wait_for("saved", 10)
        cage_after, target_after, _ = session_points(session)
        assert np.array_equal(cage_after, cage), "a target drag must not move the source cage"
        moved = np.flatnonzero(np.any(target_after != target, axis=1))
        assert moved.tolist() == [0]
        np.testing.assert_allclose(
            target_after[0] - target[0], drag / view["scale"], atol=1.5 / view["scale"]
        )
        park_mouse(display, window)
        # The arm moved: the screen changed where it was and where it is now ...
        # (Inside an arm near its tip: halfway between the curve's two sides there, at t = 0.2 and
        # t = 0.8 of the span that bulges towards control point 0.)
        centre = np.array([320.0, 250.0])
        sides = curve_matrix(len(target))[[SAMPLES_PER_SPAN // 5, SAMPLES_PER_SPAN * 4 // 5]]
        old_arm = window_pixel(view, (sides @ target).mean(axis=0))
        new_arm = window_pixel(view, (sides @ target_after).mean(axis=0))
        dragged = shot_once(
            display, folder, "2-dragged", lambda pixels: box_difference(before, pixels, old_arm, 5) > 30
        )
        assert box_difference(before, dragged, old_arm, 5) > 30
        assert box_difference(before, dragged, new_arm, 5) > 30
        # ... and not at the far end of the starfish (the bottom-left arm's tip).
        far = window_pixel(view, cage[12] + 0.3 * (centre - cage[12]))
        assert box_difference(before, dragged, far, 30) < 6  # global coordinates: a sub-pixel shift at most

        # Undo, redo (both shortcuts), each saved at once.
        xdotool(display, "key", "ctrl+z")
        viewer.wait_for("saved", 10)
        assert np.array_equal(session_points(session)[1], target)
        park_mouse(display, window)
        undone = shot(display, folder, "3-undone")
        assert changed_fraction(before, undone) < 0.002
        xdotool(display, "key", "ctrl+shift+z")
        viewer.wait_for("saved", 10)
        assert np.array_equal(session_points(session)[1], target_after)
        xdotool(display, "key", "ctrl+z")
        viewer.wait_for("saved", 10)
        xdotool(display, "key", "ctrl+y")
        viewer.wait_for("saved", 10)
        assert np.array_equal(session_points(session)[1], target_after)
        park_mouse(display, window)
        redone = shot(display, folder, "4-redone")
        assert changed_fraction(dragged, redone) < 0.002

        # Esc cancels a drag in progress: nothing changes, nothing is saved.
        other = window_pixel(view, target_after[4])
        xdotool(display, "mousemove", "--window", window, *(f"{v:.0f}" for v in other))
        time.sleep(0.2)
        xdotool(display, "mousedown", "1")
        for step in (0.3, 0.6, 1.0):
            xdotool(
                display,
                "mousemove",
                "--window",
                window,
                *(f"{v:.0f}" for v in other + step * np.array([60, 60])),
            )
            time.sleep(0.03)
        xdotool(display, "key", "Escape")
        time.sleep(0.2)
        xdotool(display, "mouseup", "1")
        park_mouse(display, window)
        cancelled = shot(display, folder, "5-cancelled")
        assert changed_fraction(redone, cancelled) < 0.002
        assert np.array_equal(session_points(session)[1], target_after)

        # Export at full resolution: exactly what `warp --session` writes.
        xdotool(display, "key", "ctrl+e")
        assert viewer.wait_for("exported", 20) == f"exported {exported}"
        warped = folder / "warped.png"
        result = subprocess.run(
            [sys.executable, "-m", "app", "warp", "--session", str(session), "--output", str(warped)],
            cwd=ROOT,
            env=env,
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert result.returncode == 0, result.stderr
        viewer_pixels, warp_pixels = read_image(exported), read_image(warped)
        assert viewer_pixels.shape == warp_pixels.shape == (480, 640, 4)
        assert np.abs(viewer_pixels.astype(int) - warp_pixels.astype(int)).max() <= 1

        # Quit with Ctrl+Q: a clean exit and the frame statistics.
        xdotool(display, "key", "ctrl+q")
        code, stderr = viewer.finish()
        assert code == 0, stderr
        frames = stats_line(viewer.lines)
        assert int(frames.group(1)) > 10
        assert float(frames.group(4)) > 0  # frames were drawn while the arm was dragged
    finally:
        viewer.kill()

    # Reopen the session: image, cage, target, kernel and view come back.
    reopened = ViewerProcess(["view", "--session", str(session), "--stats"], env, ROOT)
    try:
        window = reopened.wait_for("ready window=", 30).split("=")[1]
        reopened.wait_for("basis ", 60)
        park_mouse(display, window)
        restored = shot_once(
            display, folder, "6-restored", lambda pixels: changed_fraction(redone, pixels) < 0.002
        )
        assert changed_fraction(redone, restored) < 0.002
        close_window(display, int(window))
        code, stderr = reopened.finish()
        assert code == 0, stderr
        assert float(stats_line(reopened.lines).group(4)) == 0  # nothing was dragged
        assert np.array_equal(session_points(session)[1], target_after)
    finally:
        reopened.kill()


def test_no_display_is_an_environment_error(environment):
    env, folder = environment
    result = subprocess.run(
        [sys.executable, "-m", "app", "view", "--session", str(folder / "none.json")],
        cwd=ROOT,
        env={**env, "DISPLAY": ":1999"},
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 1
    assert result.stderr.strip().count("\n") == 0 and "display" in result.stderr


def test_tools_are_installed():
    # The window tests need these; a missing tool must fail the suite, not skip it.
    assert shutil.which("Xvfb") and shutil.which("xdotool")


def test_scripted_demo_replays_through_the_mouse_path_and_writes_frames(environment):
    env, folder = environment
    frames = folder / "frames"
    demo = ViewerProcess(
        ["demo", "pattern", "--frames", str(frames), "--fps", "8", "--max-edge", "6", "--stats"], env, ROOT
    )
    try:
        demo.wait_for("ready window=", 30)
        demo.wait_for("script done", 90)
        code, stderr = demo.finish(30)  # --frames quits when the script ends
        assert code == 0, stderr
    finally:
        demo.kill()
    stats_line(demo.lines)
    written = sorted(frames.glob("frame_*.png"))
    moves = json.loads((ASSETS / "pattern.script.json").read_text())["moves"]
    duration = max(m["at"] + m["duration"] for m in moves)
    assert abs(len(written) - duration * 8) <= 3
    first, last = read_image(written[0]), read_image(written[-1])
    assert first.shape == last.shape == (480, 640, 4)
    assert np.abs(first.astype(int) - last.astype(int)).mean() > 5  # the horseshoe closed
    # The moves went through the same handler as the mouse: one undo step each, saved.
    saved = json.loads(main_session(folder / "state", "pattern").read_text())
    target = np.array(saved["target"]["control_points"])
    for move in moves:
        np.testing.assert_allclose(target[move["point"]], move["to"], atol=0.05)


def main_session(state: Path, stem: str) -> Path:
    """The one session file of the image called `stem` in the state directory `state`."""
    (path,) = (p for p in (state / "sessions").glob(f"{stem}-*.json") if re.fullmatch(r"[^.]+\.json", p.name))
    return path


def session_image(session: Path) -> Path:
    """The image of a session file, resolved (sessions store it relative to themselves)."""
    return (session.parent / json.loads(session.read_text())["image"]).resolve()


def test_open_prompt_when_no_dialog_program_is_installed(display, environment):
    # Ctrl+O runs zenity or kdialog where one is installed; without them (this machine)
    # the viewer asks for the path in the window: type it, press Enter, the image opens.
    env, folder = environment
    session = folder / "prompt-session.json"
    no_programs = folder / "empty-bin"
    no_programs.mkdir(exist_ok=True)  # the viewer finds no zenity or kdialog on this PATH
    viewer = ViewerProcess(
        ["view", str(ASSETS / "starfish.png"), "--session", str(session)],
        {**env, "PATH": str(no_programs)},
        ROOT,
    )
    try:
        window = viewer.wait_for("ready window=", 30).split("=")[1]
        path = str(ASSETS / "pattern.png")
        xdotool(display, "windowfocus", "--sync", window)
        xdotool(display, "key", "ctrl+o")
        viewer.wait_for("text input on", 10)  # typed before, the letters would be shortcuts
        xdotool(display, "key", "ctrl+a")  # replace the proposed folder
        time.sleep(0.3)  # select-all handled before the typing
        xdotool(display, "type", "--delay", "5", path)
        xdotool(display, "key", "Return")
        # The image opens in its own session file; the one given with --session keeps the starfish.
        opened = session
        while opened == session:
            opened = Path(viewer.wait_for("saved ", 20).split(" ", 1)[1])
        assert session_image(opened) == Path(path)
        assert session_image(session) == ASSETS / "starfish.png"
        xdotool(display, "key", "ctrl+q")
        code, stderr = viewer.finish()
        assert code == 0, stderr
    finally:
        if viewer.process.poll() is None:
            viewer.process.kill()


def test_open_session_and_export_go_through_the_desktops_dialog_where_there_is_one(display, environment):
    # A stand-in zenity on PATH: portable-file-dialogs runs it as it would the real one, and it
    # answers with the path in its answer file (and notes how it was called).
    env, folder = environment
    programs = folder / "dialog-bin"
    programs.mkdir(exist_ok=True)
    answer, calls = programs / "answer", programs / "calls"
    zenity = programs / "zenity"
    zenity.write_text(f'#!/bin/sh\necho "$@" >> "{calls}"\ncat "{answer}"\n')
    zenity.chmod(0o755)
    state = folder / "state-dialogs"
    env = {**env, "TRANSFINITE_STATE_DIR": str(state), "PATH": f"{programs}{os.pathsep}{env['PATH']}"}
    viewer = ViewerProcess(["view", str(ASSETS / "starfish.png")], env, ROOT)
    try:
        window = viewer.wait_for("ready window=", 30).split("=")[1]
        viewer.wait_for("basis ", 60)
        xdotool(display, "windowfocus", "--sync", window)
        exported = folder / "from-dialog.png"
        answer.write_text(f"{exported}\n")
        xdotool(display, "key", "ctrl+e")
        assert viewer.wait_for("exported", 30) == f"exported {exported}"
        assert read_image(exported).shape == (480, 640, 4)
        session = folder / "pattern-copy.session.json"  # opened sessions are written: not the repository's
        value = json.loads((ASSETS / "pattern.session.json").read_text())
        session.write_text(json.dumps({**value, "image": str(ASSETS / "pattern.png")}))
        answer.write_text(f"{session}\n")
        xdotool(display, "key", "ctrl+shift+o")
        opened = main_session(state, "starfish")
        while opened == main_session(state, "starfish"):
            opened = Path(viewer.wait_for("saved ", 20).split(" ", 1)[1])
        assert opened == session  # a session opened is the one saved from then on
        lines = calls.read_text().splitlines()
        assert lines[0].startswith("--file-selection") and "--save" in calls.read_text()
        assert any(line.startswith(f"--file-selection --filename={state / 'sessions'}") for line in lines)
        xdotool(display, "key", "ctrl+q")
        code, stderr = viewer.finish()
        assert code == 0, stderr
    finally:
        viewer.kill()


def test_kill_and_relaunch_brings_back_the_work_and_its_undo(display, environment):
    """Drag, change the kernel, kill -9, run the identical command again: the drag is back, Ctrl+Z
    undoes it; opening another image then leaves this image's session file byte for byte unchanged."""
    env, folder = environment
    state = folder / "state-kill"
    no_programs = folder / "empty-bin"  # no zenity: Ctrl+O asks in the window
    no_programs.mkdir(exist_ok=True)
    env = {**env, "TRANSFINITE_STATE_DIR": str(state), "PATH": str(no_programs)}
    command = ["view", str(ASSETS / "starfish.png"), "--cage", str(ASSETS / "starfish.cage.json")]
    viewer = ViewerProcess(command, env, ROOT)
    try:
        window = viewer.wait_for("ready window=", 30).split("=")[1]
        viewer.wait_for("basis ", 60)
        session = main_session(state, "starfish")
        cage, target, value = session_points(session)
        drag_point(display, window, window_pixel(value["view"], target[0]), np.array([80.0, 30.0]))
        viewer.wait_for("saved", 10)
        xdotool(display, "key", "k")  # the next kernel
        viewer.wait_for("saved", 10)
        viewer.wait_for("drawn basis ", 60)  # the new kernel's, on screen
        _, dragged, value = session_points(session)
        assert value["kernel"] != "poisson" and not np.array_equal(dragged, target)  # from the default
        park_mouse(display, window)
        before_kill = shot(display, folder, "kill-1-before")
    finally:
        viewer.kill()  # SIGKILL: no chance to save anything more

    again = ViewerProcess(command, env, ROOT)  # the identical command
    try:
        window = again.wait_for("ready window=", 30).split("=")[1]
        again.wait_for("basis ", 60)
        assert main_session(state, "starfish") == session
        _, restored, restored_value = session_points(session)
        assert np.array_equal(restored, dragged) and restored_value["kernel"] == value["kernel"]
        park_mouse(display, window)
        relaunched = shot_once(
            display, folder, "kill-2-relaunched", lambda pixels: changed_fraction(before_kill, pixels) < 0.002
        )
        assert changed_fraction(before_kill, relaunched) < 0.002
        xdotool(display, "key", "ctrl+z")  # the kernel change
        again.wait_for("saved", 10)
        xdotool(display, "key", "ctrl+z")  # the drag
        again.wait_for("saved", 10)
        _, undone, undone_value = session_points(session)
        assert np.array_equal(undone, target) and undone_value["kernel"] == "poisson"
        xdotool(display, "key", "ctrl+y")  # and forward again to the killed state
        xdotool(display, "key", "ctrl+y")
        deadline = time.monotonic() + 10
        while session_points(session)[2]["kernel"] != value["kernel"] and time.monotonic() < deadline:
            time.sleep(0.1)
        first_bytes = session.read_bytes()
        assert np.array_equal(session_points(session)[1], dragged)
        assert json.loads(first_bytes)["kernel"] == value["kernel"]

        xdotool(display, "windowfocus", "--sync", window)
        xdotool(display, "key", "ctrl+o")
        again.wait_for("text input on", 10)  # typed before, the letters would be shortcuts
        xdotool(display, "key", "ctrl+a")
        time.sleep(0.3)  # select-all handled before the typing (else the text was appended)
        xdotool(display, "type", "--delay", "5", str(ASSETS / "pattern.png"))
        xdotool(display, "key", "Return")
        opened = session
        while opened == session:
            opened = Path(again.wait_for("saved ", 20).split(" ", 1)[1])
        assert opened == main_session(state, "pattern")
        xdotool(display, "key", "ctrl+q")
        code, stderr = again.finish()
        assert code == 0, stderr
        assert "note: restored starfish.png from the session (2 undo steps)" in stderr
        assert session.read_bytes() == first_bytes
    finally:
        again.kill()


@pytest.mark.parametrize("kernel", ["poisson", "pgw"])
def test_a_drag_during_the_first_computation_survives_kill_9(display, environment, kernel):
    """Launch, drag at once while the first mesh and basis are still being computed (nothing drawn
    but the cage), kill -9: the identical command brings the drag back."""
    env, folder = environment
    state, cache = folder / f"state-early-{kernel}", folder / f"cache-early-{kernel}"  # G not cached
    env = {**env, "TRANSFINITE_STATE_DIR": str(state), "TRANSFINITE_CACHE_DIR": str(cache)}
    command = ["view", str(ASSETS / "starfish.png"), "--cage", str(ASSETS / "starfish.cage.json")]
    # A mesh of 200,000 vertices keeps the first computation going for a second or more: the
    # default kernel's basis at the usual 6,000 takes ~0.15 s, less than the drag.
    command += ["--kernel", kernel, "--vertices", "200000"]
    viewer = ViewerProcess(command, env, ROOT)
    try:
        window = viewer.wait_for("ready window=", 30).split("=")[1]
        session = main_session(state, "starfish")
        _, target, value = session_points(session)
        drag_point(display, window, window_pixel(value["view"], target[0]), np.array([80.0, 30.0]))
        viewer.wait_for("saved", 10)
        assert not any(line.startswith("basis ") for line in viewer.lines)  # still computing
        _, dragged, value = session_points(session)
        assert np.flatnonzero(np.any(dragged != target, axis=1)).tolist() == [0]
        assert value["kernel"] == kernel
        deadline = time.monotonic() + 10  # the precompute worker, and the check worker it forks
        while len(workers := viewer.descendants()) < 2 and time.monotonic() < deadline:
            time.sleep(0.1)
        assert len(workers) == 2, workers
    finally:
        viewer.kill()
    # The workers see the viewer gone (their request pipes closed) and end, mid-computation too.
    assert wait_until_ended(workers, 10) == []

    again = ViewerProcess(command, env, ROOT)
    try:
        again.wait_for("ready window=", 30)
        assert main_session(state, "starfish") == session
        _, restored, value = session_points(session)
        assert np.array_equal(restored, dragged) and value["kernel"] == kernel
        xdotool(display, "key", "ctrl+q")
        code, stderr = again.finish()
        assert code == 0, stderr
        assert "note: restored starfish.png from the session" in stderr
    finally:
        again.kill()


def starfish_viewer(environment, state_name: str) -> tuple[ViewerProcess, Path]:
    """``view`` on the starfish image and cage with a state directory of its own (folder/state_name)."""
    env, folder = environment
    state = folder / state_name
    command = ["view", str(ASSETS / "starfish.png"), "--cage", str(ASSETS / "starfish.cage.json")]
    return ViewerProcess(command, {**env, "TRANSFINITE_STATE_DIR": str(state)}, ROOT), state


def test_rough_edges_redraw_escape_delete_group_moves_zoom_and_resize(display, environment):
    from app.viewer import controller
    from app.viewer.state import AppState, Document, History, Snapshot

    viewer, state = starfish_viewer(environment, "state-edges")
    try:
        window = viewer.wait_for("ready window=", 30).split("=")[1]
        combo = viewer.wait_for("spot kernel=").split("=")[1].split(",")
        viewer.wait_for("basis ", 60)
        session = main_session(state, "starfish")
        cage, target, value = session_points(session)
        view = value["view"]

        # A click opens the kernel list at once: no mouse motion is needed for the next frame
        # (an idle viewer would otherwise sleep for IDLE_WAIT).
        xdotool(display, "mousemove", "--window", window, *combo)
        time.sleep(0.3)
        clicked = time.monotonic()
        xdotool(display, "click", "1")
        viewer.wait_for("popup open", 5)
        assert time.monotonic() - clicked < 0.5 * IDLE_WAIT
        xdotool(display, "key", "Escape")  # Esc closes it
        viewer.wait_for("popup closed", 5)

        # With the list open, a press on a handle closes it and starts the drag: nothing swallowed.
        xdotool(display, "click", "1")
        viewer.wait_for("popup open", 5)
        drag_point(display, window, window_pixel(view, target[3]), np.array([40.0, 20.0]))
        viewer.wait_for("popup closed", 5)
        _, moved, _ = wait_for_session(session, lambda c, t, v: not np.array_equal(t, target))
        assert np.flatnonzero(np.any(moved != target, axis=1)).tolist() == [3]

        # Delete and Backspace in deform mode delete nothing (point 3 is selected).
        xdotool(display, "key", "Delete")
        xdotool(display, "key", "BackSpace")
        time.sleep(0.8)
        assert len(session_points(session)[0]) == len(cage)

        # Shift+click adds point 6 to the selection; dragging it moves 3 and 6 together.
        xdotool(display, "mousemove", "--window", window, *(f"{v:.0f}" for v in window_pixel(view, moved[6])))
        time.sleep(0.2)
        xdotool(display, "keydown", "shift")
        xdotool(display, "click", "1")
        xdotool(display, "keyup", "shift")
        time.sleep(0.3)
        drag_point(display, window, window_pixel(view, moved[6]), np.array([-30.0, 24.0]))
        _, both, _ = wait_for_session(session, lambda c, t, v: not np.array_equal(t, moved))
        assert np.flatnonzero(np.any(both != moved, axis=1)).tolist() == [3, 6]
        np.testing.assert_allclose(both[3] - moved[3], both[6] - moved[6], atol=1e-9)

        # Zoom keys: 1 is 100 %, + and - zoom by 1.5, 0 fits again.
        park_mouse(display, window)
        fitted = view["scale"]
        xdotool(display, "key", "1")
        wait_for_session(session, lambda c, t, v: v["view"]["scale"] == 1.0)
        xdotool(display, "key", "plus")
        wait_for_session(session, lambda c, t, v: abs(v["view"]["scale"] - 1.5) < 1e-9)
        xdotool(display, "key", "minus")
        xdotool(display, "key", "minus")
        wait_for_session(session, lambda c, t, v: abs(v["view"]["scale"] - 1 / 1.5) < 1e-9)
        xdotool(display, "key", "0")
        wait_for_session(session, lambda c, t, v: v["view"]["scale"] == fitted)

        # A smaller window fits the image again instead of cutting it off.
        xdotool(display, "windowsize", window, "900", "640")
        image = read_image(ASSETS / "starfish.png")
        expected = AppState(
            Document(History(Snapshot(Path("s.png"), cage, cage)), None, image, Path("s.json"))
        )
        expected.screen.window_size, expected.screen.canvas_left = (900, 640), 300.0
        controller.fit_view(expected, None)
        _, _, resized = wait_for_session(
            session, lambda c, t, v: abs(v["view"]["scale"] - expected.display.viewport.scale) < 1e-9
        )
        assert expected.display.viewport.scale < fitted
        np.testing.assert_allclose(resized["view"]["offset"], expected.display.viewport.offset)
        xdotool(display, "key", "ctrl+q")
        code, stderr = viewer.finish()
        assert code == 0, stderr
    finally:
        viewer.kill()


def test_drawing_a_new_cage_through_clicks_with_corners_backspace_enter_and_escape(display, environment):
    from core.curves.bspline import ClosedBSpline

    viewer, state = starfish_viewer(environment, "state-draw")
    try:
        window = viewer.wait_for("ready window=", 30).split("=")[1]
        viewer.wait_for("basis ", 60)
        session = main_session(state, "starfish")
        original, _, value = session_points(session)
        view = value["view"]
        clicked = []  # window pixels of the points placed

        def click_at(point, repeat=1, ctrl=False):
            x, y = (round(v) for v in window_pixel(view, point))
            xdotool(display, "mousemove", "--window", window, str(x), str(y))
            time.sleep(0.15)
            if ctrl:
                xdotool(display, "keydown", "ctrl")
            xdotool(display, "click", "--repeat", str(repeat), "--delay", "80", "1")
            if ctrl:
                xdotool(display, "keyup", "ctrl")
            time.sleep(0.5)  # longer than a double click
            return np.array([x, y], dtype=float)

        # A house: the clicks are points on the outline (the default), its corners sharp.
        house = np.array([[140.0, 400.0], [500.0, 400.0], [500.0, 200.0], [320.0, 90.0], [140.0, 200.0]])
        xdotool(display, "windowfocus", "--sync", window)
        xdotool(display, "key", "n")
        clicked.append(click_at(house[0], ctrl=True))  # Ctrl+click: a sharp corner
        clicked.append(click_at(house[1], repeat=2))  # a double click: a sharp corner
        click_at([320.0, 240.0])  # a point too many ...
        xdotool(display, "key", "BackSpace")  # ... removed again
        clicked.append(click_at(house[2]))
        clicked.append(click_at(house[3]))
        clicked.append(click_at(house[4]))
        xdotool(display, "key", "Return")  # closes the curve
        time.sleep(0.3)
        assert np.array_equal(session_points(session)[0], original)  # nothing saved while drawing
        xdotool(display, "key", "Return")  # and makes it the cage
        cage, target, _ = wait_for_session(session, lambda c, t, v: len(c) != len(original))
        assert len(cage) == 7 and np.array_equal(cage, target)
        # The curve passes within half a window pixel of every click ...
        curve = window_pixel(view, ClosedBSpline(cage)(np.linspace(0.0, len(cage), 20000, endpoint=False)))
        for point in clicked:
            assert np.hypot(*(curve - point).T).min() <= 0.5, point
        # ... and the two corners are doubled control points at their clicks.
        for point in clicked[:2]:
            (rows,) = np.nonzero(np.all(np.abs(window_pixel(view, cage) - point) < 1e-6, axis=1))
            assert len(rows) == 2 and rows[1] == rows[0] + 1, (point, cage)

        # Esc abandons a new cage: the one just made stays.
        xdotool(display, "key", "n")
        click_at([200.0, 200.0])
        click_at([300.0, 200.0])
        xdotool(display, "key", "Escape")
        time.sleep(0.3)
        xdotool(display, "key", "ctrl+s")
        viewer.wait_for("saved", 10)
        np.testing.assert_array_equal(session_points(session)[0], cage)
        xdotool(display, "key", "ctrl+q")
        code, stderr = viewer.finish()
        assert code == 0, stderr
    finally:
        viewer.kill()


def test_keyframes_are_added_played_exported_and_saved(display, environment):
    env, folder = environment
    session = folder / "animated.json"
    movie = folder / "animated.gif"
    viewer = ViewerProcess(
        [
            "view",
            str(ASSETS / "starfish.png"),
            "--cage",
            str(ASSETS / "starfish.cage.json"),
            "--session",
            str(session),
            "--stats",
        ],
        env,
        ROOT,
    )
    try:
        window = viewer.wait_for("ready window=", 30).split("=")[1]
        viewer.wait_for("basis ", 60)
        cage, _, value = session_points(session)
        view = value["view"]
        xdotool(display, "mousemove", "--window", window, "1250", "40")
        xdotool(display, "key", "i")  # a keyframe at 0 s: the rest pose
        viewer.wait_for("saved", 10)
        xdotool(display, "key", "shift+Right")  # the time on to 1 s
        # Drag the right arm's tip (control point 4) to a new pose, and keyframe it at 1 s.
        start, shift = window_pixel(view, cage[4]), np.array([60.0, -80.0])
        xdotool(display, "mousemove", "--window", window, *(f"{v:.0f}" for v in start))
        time.sleep(0.2)
        xdotool(display, "mousedown", "1")
        for step in np.linspace(0.02, 1.0, 50):
            xdotool(display, "mousemove", "--window", window, *(f"{v:.0f}" for v in start + step * shift))
            time.sleep(0.02)
        xdotool(display, "mouseup", "1")
        viewer.wait_for("saved", 10)  # the release is saved first, before the frame that draws it
        dragged = viewer.wait_for("drag done", 10)
        # With a keyframe already, the drag at 1 s made a keyframe there (auto-key).
        keyframes = json.loads(session.read_text())["keyframes"]
        assert [k["time"] for k in keyframes] == [0.0, 1.0]
        assert np.array_equal(keyframes[0]["target"]["control_points"], cage)
        pose = np.array(keyframes[1]["target"]["control_points"])
        np.testing.assert_allclose(pose[4] - cage[4], shift / view["scale"], atol=1.5 / view["scale"])
        park_mouse(display, window)
        posed = shot(display, folder, "k1-posed")
        xdotool(display, "key", "shift+Left")  # back to 0 s: the rest pose is shown again
        park_mouse(display, window)
        rest = shot(display, folder, "k2-rest")
        tip = window_pixel(view, 0.8 * cage[4] + 0.2 * np.array([320.0, 250.0]))
        assert box_difference(posed, rest, tip, 8) > 20

        # Play (Space), let it loop for a while, pause: every frame was drawn, at the normal rate.
        xdotool(display, "key", "space")
        viewer.wait_for("playback started", 10)
        time.sleep(1.5)  # ~100 frames on a quiet machine, 30 asked
        xdotool(display, "key", "space")
        paused = viewer.wait_for("playback paused", 10)
        frames, median, rate = (float(part.split("=")[1]) for part in paused.split()[2:5])
        assert frames >= 30, paused
        # No more frames than the screen shows (Xvfb says no refresh rate: 60 a second), although
        # the software renderer could draw ~80.
        assert rate <= 1.1 * 60, paused
        # A frame of playback costs what a frame of dragging does (one G @ P' product, one upload):
        # 60 fps or better on a quiet machine.  Other processes share this one's two cores, and the
        # software rasteriser's time grows with them; so the bound is also relative to the drags
        # just before and just after playing.
        xdotool(display, "key", "shift+Left")
        start = window_pixel(view, cage[12])
        xdotool(display, "mousemove", "--window", window, *(f"{v:.0f}" for v in start))
        time.sleep(0.2)
        xdotool(display, "mousedown", "1")
        for step in np.linspace(0.02, 1.0, 50):
            xdotool(display, "mousemove", "--window", window, *(f"{v:.0f}" for v in start - step * shift))
            time.sleep(0.02)
        xdotool(display, "mouseup", "1")
        again = viewer.wait_for("drag done", 10)
        drag_median = max(float(line.split()[3].split("=")[1]) for line in (dragged, again))
        assert median <= max(16.7, 1.5 * drag_median), (paused, dragged, again)

        # Export the animation through the in-window prompt (no file dialog program here).
        xdotool(display, "key", "ctrl+e")
        viewer.wait_for("text input on", 10)
        xdotool(display, "key", "ctrl+a")
        time.sleep(0.3)  # select-all handled before the typing (else the text was appended)
        xdotool(display, "type", str(movie))
        xdotool(display, "key", "Return")
        assert viewer.wait_for("exported", 60) == f"exported {movie}"
        from PIL import Image

        with Image.open(movie) as gif:
            assert gif.n_frames == 31  # 1 s at 30 fps, both ends included
        # A folder of PNG frames, then Ctrl+Shift+E: the same folder again (it once wrote frames.png).
        frame_folder = movie.with_name("frames")
        xdotool(display, "key", "ctrl+e")
        viewer.wait_for("text input on", 10)
        xdotool(display, "key", "ctrl+a")
        time.sleep(0.3)  # select-all handled before the typing (else the text was appended)
        xdotool(display, "type", f"{frame_folder}/")
        xdotool(display, "key", "Return")
        assert viewer.wait_for("exported", 60) == f"exported {frame_folder}"
        assert len(list(frame_folder.glob("*.png"))) == 31
        for frame in frame_folder.glob("*.png"):
            frame.unlink()
        xdotool(display, "key", "ctrl+shift+e")
        assert viewer.wait_for("exported", 60) == f"exported {frame_folder}"
        assert len(list(frame_folder.glob("*.png"))) == 31 and not frame_folder.with_suffix(".png").exists()
        xdotool(display, "key", "ctrl+q")
        code, stderr = viewer.finish()
        assert code == 0, stderr
    finally:
        viewer.kill()
    assert len(json.loads(session.read_text())["keyframes"]) == 2


def test_a_drag_between_keyframes_is_keyed_in_the_saved_session_and_undone(display, environment):
    env, folder = environment
    session = folder / "autokey.json"
    cage = np.array(json.loads((ASSETS / "starfish.cage.json").read_text())["control_points"], dtype=float)
    pose = cage.copy()
    pose[4] += [40.0, -70.0]  # the right arm up at 2 s
    value = {
        "image": str(ASSETS / "starfish.png"),
        "cage": {"control_points": cage.tolist()},
        "target": {"control_points": cage.tolist()},
        "kernel": "poisson",
        "view": {"scale": 1.0, "offset": [450.0, 250.0]},
        "keyframes": [
            {"time": 0.0, "target": {"control_points": cage.tolist()}},
            {"time": 2.0, "target": {"control_points": pose.tolist()}},
        ],
        "interpolation": "linear",
    }
    session.write_text(json.dumps(value))
    viewer = ViewerProcess(["view", "--session", str(session)], env, ROOT)
    try:
        window = viewer.wait_for("ready window=", 30).split("=")[1]
        viewer.wait_for("basis ", 60)
        xdotool(display, "windowfocus", "--sync", window)
        xdotool(display, "key", "shift+Right")  # 1 s: the arm halfway up
        time.sleep(0.3)
        view = value["view"]
        shift = np.array([-50.0, 40.0])
        drag_point(display, window, window_pixel(view, cage[12]), shift)  # the bottom-left arm's tip
        _, _, saved = wait_for_session(session, lambda c, t, v: len(v["keyframes"]) == 3)
        keyframes = saved["keyframes"]
        assert [k["time"] for k in keyframes] == [0.0, 1.0, 2.0]
        keyed = np.array(keyframes[1]["target"]["control_points"])
        np.testing.assert_allclose(keyed[12] - cage[12], shift / view["scale"], atol=1.5)
        np.testing.assert_allclose(keyed[4], 0.5 * (cage[4] + pose[4]), atol=1e-9)  # the pose at 1 s
        assert np.array_equal(saved["target"]["control_points"], keyframes[1]["target"]["control_points"])
        xdotool(display, "key", "ctrl+z")
        _, _, undone = wait_for_session(session, lambda c, t, v: len(v["keyframes"]) == 2)
        assert [k["time"] for k in undone["keyframes"]] == [0.0, 2.0]
        xdotool(display, "key", "ctrl+q")
        code, stderr = viewer.finish()
        assert code == 0, stderr
    finally:
        viewer.kill()


def test_distortion_view_shows_the_exact_folds_of_a_point_kernel(display, environment):
    from app.io.session import KernelChoice, Session, ViewerSettings, write_session
    from app.render.viewport import View

    env, folder = environment
    cage = np.array(json.loads((ASSETS / "starfish.cage.json").read_text())["control_points"])
    target = cage.copy()
    target[0] = (320.0, 300.0)  # the top arm's tip pulled down through the body: a fold
    session = folder / "distortion.json"
    view = {"scale": 1.4, "offset": [360.0, 40.0]}
    write_session(
        session,
        Session(
            ASSETS / "starfish.png",
            cage,
            target,
            KernelChoice("inverse-cube-mean"),
            View(view["scale"], tuple(view["offset"])),
            viewer=ViewerSettings(content="distortion", distortion="area"),
        ),
    )
    viewer = ViewerProcess(["view", "--session", str(session)], env, ROOT)
    try:
        viewer.wait_for("ready window=", 30)
        line = viewer.wait_for("distortion ", 300)  # the first run compiles the gradient solver
        fields = dict(part.split("=") for part in line.split()[1:])
        assert fields["measure"] == "area" and int(fields["exact"]) > 0.9 * int(fields["vertices"])
        assert int(fields["folded"]) > 0 and float(fields["min_det"]) < 0
        folded = shot(display, folder, "distortion-area")
        canvas = folded[:STATUS_TOP, PANEL_RIGHT:COLOUR_BAR_LEFT]
        black = canvas.max(axis=-1) < 8  # folded vertices are drawn black
        # The fold is where the tip went: around the deformed top arm, inside the target.
        rows, columns = np.nonzero(black)
        tip = window_pixel(view, target[0]) - (PANEL_RIGHT, 0)
        assert black.sum() > 200
        assert np.median(np.hypot(columns - tip[0], rows - tip[1])) < 200 * view["scale"]
        xdotool(display, "key", "shift+1")  # the warped image: no black anywhere

        def black_gone(pixels: np.ndarray) -> bool:
            return (
                pixels[:STATUS_TOP, PANEL_RIGHT:COLOUR_BAR_LEFT].max(axis=-1) < 8
            ).sum() < 0.05 * black.sum()

        image = shot_once(display, folder, "distortion-image", black_gone)
        assert black_gone(image)
        xdotool(display, "key", "ctrl+q")
        code, stderr = viewer.finish()
        assert code == 0, stderr
    finally:
        viewer.kill()
    assert json.loads(session.read_text())["viewer"]["content"] == "image"


def test_a_dense_mesh_is_dragged_through_its_preview_mesh(display, environment):
    """~55k vertices: the precompute adds a ~20k-vertex preview mesh, drawn while the handle is held;
    mid-drag the screen shows the moved arm, and on release the dense mesh's exact picture differs
    from that preview frame in almost no pixel."""
    env, folder = environment
    session = folder / "dense-session.json"
    viewer = ViewerProcess(
        [
            "view",
            str(ASSETS / "starfish.png"),
            "--cage",
            str(ASSETS / "starfish.cage.json"),
            "--session",
            str(session),
            "--vertices",
            "55000",
            "--stats",
        ],
        env,
        ROOT,
    )
    try:
        window = viewer.wait_for("ready window=", 30).split("=")[1]
        basis = viewer.wait_for("basis ", 180)
        fields = dict(item.split("=") for item in basis.split()[1:])
        assert int(fields["vertices"]) > 50_000 and 15_000 < int(fields["preview"]) < 25_000, basis
        viewer.wait_for("drawn basis ", 60)  # on screen (a frame of 55,000 vertices is slow)
        cage, target, value = session_points(session)
        view = value["view"]
        park_mouse(display, window)
        before = shot(display, folder, "dense-1-start")
        press_and_move(display, window, window_pixel(view, target[0]), np.array([90.0, 40.0]))
        viewer.wait_for("preview on", 30)  # a loaded machine draws the first frames slowly
        held = shot(display, folder, "dense-2-held")  # the preview mesh, button still down
        xdotool(display, "mouseup", "1")
        # Saved before the frame that draws the dense mesh again: a viewer killed during that slow
        # frame keeps the drag ("preview off" after "saved"; wait_for reads the lines in order).
        viewer.wait_for("saved", 30)
        viewer.wait_for("preview off", 30)
        released = shot(display, folder, "dense-3-released")  # the dense mesh, exact
        _, target_after, _ = session_points(session)
        sides = curve_matrix(len(target))[[SAMPLES_PER_SPAN // 5, SAMPLES_PER_SPAN * 4 // 5]]
        new_arm = window_pixel(view, (sides @ target_after).mean(axis=0))
        assert box_difference(before, held, new_arm, 5) > 30  # the arm moved while held
        assert changed_fraction(held, released) < 0.002
        xdotool(display, "key", "ctrl+q")
        code, stderr = viewer.finish()
        assert code == 0, stderr
        assert float(stats_line(viewer.lines).group(4)) > 0  # frames were drawn while dragging
    finally:
        viewer.kill()


def test_a_press_queued_behind_a_slow_frame_grabs_the_handle_it_was_made_on(display, environment):
    """Press, motion and release sent in one burst (as when frames are slow and events queue up):
    the press counts where it was made, not where the pointer is when the viewer reads it."""
    env, folder = environment
    session = folder / "burst-session.json"
    viewer = ViewerProcess(
        ["view", str(ASSETS / "starfish.png"), "--cage", str(ASSETS / "starfish.cage.json"), "--session",
         str(session)],
        env,
        ROOT,
    )  # fmt: skip
    try:
        window = viewer.wait_for("ready window=", 30).split("=")[1]
        viewer.wait_for("basis ", 60)
        _, target, value = session_points(session)
        start = window_pixel(value["view"], target[0])
        xdotool(display, "mousemove", "--window", window, *(f"{v:.0f}" for v in start))
        time.sleep(0.3)
        offset, burst = np.array([70.0, 30.0]), ["mousedown", "1"]
        for step in np.linspace(0.1, 1.0, 10):
            burst += ["mousemove", "--window", window, *(f"{v:.0f}" for v in start + step * offset)]
        xdotool(display, *burst, "mouseup", "1")
        viewer.wait_for("saved", 20)
        _, after, _ = session_points(session)
        assert np.flatnonzero(np.any(after != target, axis=1)).tolist() == [0]
        np.testing.assert_allclose(after[0] - target[0], offset / value["view"]["scale"], atol=1.5)
        xdotool(display, "key", "ctrl+q")
        assert viewer.finish()[0] == 0
    finally:
        viewer.kill()
