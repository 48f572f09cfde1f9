"""app.viewer.window_fit: where the window opens; and the real window on small and large screens (Xvfb)."""

from __future__ import annotations

import os
import re
import time
from pathlib import Path

import numpy as np
import pytest
from support.paths import ROOT
from support.viewer_harness import ViewerProcess, save_png, screenshot, start_xvfb, xdotool

from app.viewer.controller import STATUS_HEIGHT
from app.viewer.window_fit import monitor_work_area, opening_rectangle

pytestmark = pytest.mark.slow

ASSETS = ROOT / "assets"


def test_a_first_window_takes_nine_tenths_of_the_work_area_centred():
    assert opening_rectangle((0, 0, 1366, 768)) == (68, 38, 1229, 691)
    assert opening_rectangle((0, 32, 1920, 1048)) == (96, 84, 1728, 943)  # below a top bar


def test_a_saved_window_comes_back_where_it_was_if_it_fits():
    assert opening_rectangle((0, 0, 1920, 1080), saved=(40, 30, 1000, 600)) == (40, 30, 1000, 600)


def test_the_window_is_never_larger_than_the_work_area_nor_outside_it():
    area = (0, 0, 1366, 768)
    # Saved on a larger screen: as large as this one, on it.
    assert opening_rectangle(area, saved=(300, 200, 1920, 1080)) == (0, 0, 1366, 768)
    # Saved on a monitor that is gone (right of this one): moved back, not shrunk.
    assert opening_rectangle(area, saved=(2000, 100, 800, 600)) == (566, 100, 800, 600)
    # Asked for on the command line: that size, centred, but within the screen.
    assert opening_rectangle(area, saved=(0, 0, 500, 500), asked=(1280, 1024)) == (43, 0, 1280, 768)
    # Absurdly small: the smallest the layout is made for.
    assert opening_rectangle(area, saved=(10, 10, 50, 20))[2:] == (400, 300)
    for rectangle in (opening_rectangle(area, asked=(5000, 5000)), opening_rectangle((0, 0, 300, 200))):
        x, y, width, height = rectangle
        assert x >= 0 and y >= 0 and x + width <= area[2] and y + height <= area[3]


def test_the_work_area_is_the_monitor_that_held_the_window():
    left, right = (0, 0, 1920, 1080), (1920, 0, 1366, 768)
    assert monitor_work_area([left, right], (2100, 100, 800, 500)) == right
    assert monitor_work_area([left, right], (5000, 100, 800, 500)) == left  # unplugged: the primary
    assert monitor_work_area([right, left], None) == right


def window_geometry(display: str, window: str) -> tuple[int, int, int, int]:
    text = xdotool(display, "getwindowgeometry", window)
    x, y = (int(v) for v in re.search(r"Position: (-?\d+),(-?\d+)", text).groups())
    width, height = (int(v) for v in re.search(r"Geometry: (\d+)x(\d+)", text).groups())
    return x, y, width, height


def open_viewer(display: str, state: Path, folder: Path) -> tuple[ViewerProcess, str]:
    env = {
        **os.environ,
        "DISPLAY": display,
        "TRANSFINITE_CACHE_DIR": str(folder / "cache"),
        "TRANSFINITE_STATE_DIR": str(state),
    }
    command = ["view", str(ASSETS / "starfish.png"), "--cage", str(ASSETS / "starfish.cage.json")]
    viewer = ViewerProcess(command, env, ROOT, window_size=None)
    window = viewer.wait_for("ready window=", 30).split("=")[1]
    viewer.wait_for("basis ", 60)
    time.sleep(0.5)
    return viewer, window


def quit_viewer(viewer: ViewerProcess, display: str, window: str) -> None:
    # Presses only: the viewer quits on the press of q, and a release sent to the window it has
    # just destroyed fails in xdotool with BadWindow (a race the idle viewer, woken at once by the
    # event, lost more often than not).
    xdotool(display, "keydown", "--window", window, "ctrl+q")
    code, stderr = viewer.finish()
    assert code == 0, stderr


def status_line_is_drawn(display: str, rectangle, folder: Path, name: str) -> bool:
    """Whether the bottom strip of the window holds the status line's light text on its dark bar."""
    pixels = screenshot(display)
    save_png(folder / f"{name}.png", pixels)
    x, y, width, height = rectangle
    strip = pixels[y + height - 24 : y + height - 4, x : x + min(width, 500)].astype(int)
    return bool((strip.min(axis=-1) > 170).sum() > 100)  # the text "poisson | 6,332 vertices | ..."


@pytest.mark.parametrize("screen", [(1366, 768), (1920, 1080)])
def test_the_window_fits_the_screen_and_comes_back_at_the_size_it_was_left(screen, tmp_path):
    server, display = start_xvfb(screen)
    state = tmp_path / "state"
    try:
        viewer, window = open_viewer(display, state, tmp_path)
        try:
            rectangle = window_geometry(display, window)
            x, y, width, height = rectangle
            assert x >= 0 and y >= 0 and x + width <= screen[0] and y + height <= screen[1], rectangle
            np.testing.assert_allclose([width, height], 0.9 * np.array(screen), atol=1)
            assert status_line_is_drawn(display, rectangle, tmp_path, "opened")
            # The whole panel is on screen above the status line, nothing of it scrolled away (on
            # the small screen its "Show" and "Animation" sections start folded).
            # (The last layout before the basis arrived: with the progress bar, the tallest.)
            line = [line for line in viewer.lines if line.startswith("spot panel=")][-1]
            bottom, hidden = (float(v) for v in line.split("=")[1].split(","))
            assert 0.5 * height < bottom <= height - STATUS_HEIGHT and hidden == 0, line
            # The user makes it smaller and moves it; the next viewer opens there.
            smaller = (40, 30, screen[0] // 2 + 100, screen[1] // 2 + 60)
            xdotool(display, "windowsize", window, str(smaller[2]), str(smaller[3]))
            xdotool(display, "windowmove", window, str(smaller[0]), str(smaller[1]))
            time.sleep(0.5)
            assert window_geometry(display, window) == smaller
            quit_viewer(viewer, display, window)
        finally:
            viewer.kill()
        viewer, window = open_viewer(display, state, tmp_path)
        try:
            assert window_geometry(display, window) == smaller
            assert status_line_is_drawn(display, smaller, tmp_path, "reopened")
            quit_viewer(viewer, display, window)
        finally:
            viewer.kill()
    finally:
        server.terminate()
        server.wait(timeout=10)
