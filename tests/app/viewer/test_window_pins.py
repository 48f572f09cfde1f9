"""The pin tool in the real viewer window under Xvfb (xdotool input): T, two clicks pin the starfish,
dragging the arm's pin turns the picture (the similarity that places both pins), the release's
status line says what is proven, the session holds the pins and the target; Ctrl+Z takes the move
back; a right-click removes a pin.

Xvfb and xdotool are required: without them this test fails, it never skips.  The screenshots are
kept in the test's temporary directory (and under ``$VIEWER_SCREENSHOTS`` when set).
"""

from __future__ import annotations

import time

import numpy as np
import pytest
from support.paths import ROOT
from support.viewer_harness import (
    STARFISH_CAGE,
    ViewerProcess,
    changed_fraction,
    drag_point,
    park_mouse,
    shot,
    starfish_session,
    viewer_environment,
    wait_for_session,
    window_pixel,
    xdotool,
)

pytestmark = pytest.mark.slow

#: Image pixels: a pin on the starfish's body, one on its top arm, and where the arm's pin is dragged.
BODY, ARM, MOVED = np.array([320.0, 250.0]), np.array([320.0, 100.0]), np.array([270.0, 95.0])


def similarity_residual(source: np.ndarray, target: np.ndarray) -> float:
    """Largest distance of `target` from the best similarity image of `source`, and that similarity."""
    z, w = source @ [1, 1j], target @ [1, 1j]
    design = np.column_stack([z, np.ones_like(z)])
    coefficients = np.linalg.lstsq(design, w, rcond=None)[0]
    return float(np.abs(design @ coefficients - w).max()), coefficients


def viewer_spot(viewer: ViewerProcess, name: str) -> list[str]:
    """The window point (x, y) of the widget `name`, from the last ``spot NAME=X,Y`` line said."""
    said = [line for line in viewer.lines if line.startswith(f"spot {name}=")]
    return said[-1].split("=")[1].split(",")


def pins_of(value: dict) -> list:
    return [(pin["at"], pin["to"]) for pin in value.get("pins", [])]


def test_pins_added_dragged_undone_and_removed_in_the_window(display, tmp_path):
    env = viewer_environment(display, tmp_path)
    cage = STARFISH_CAGE
    view = {"scale": 1.0, "offset": [450.0, 250.0]}
    session = tmp_path / "starfish.json"
    starfish_session(session, view)
    viewer = ViewerProcess(["view", "--session", str(session)], env, ROOT)
    try:
        window = viewer.wait_for("ready window=", 30).split("=")[1]
        viewer.wait_for("basis ", 60)
        xdotool(display, "windowfocus", "--sync", window)
        xdotool(display, "key", "t")
        wait_for_session(session, lambda c, t, v: v["viewer"]["mode"] == "pins")
        for index, point in enumerate((BODY, ARM)):
            x, y = window_pixel(view, point)
            xdotool(display, "mousemove", "--window", window, f"{x:.0f}", f"{y:.0f}", "click", "1")
            said = viewer.wait_for(f"status said pin {index} added at", 30)
            assert said == f"status said pin {index} added at {point[0]:.0f}, {point[1]:.0f}: drag it"
        _, target, saved = wait_for_session(session, lambda c, t, v: len(v.get("pins", [])) == 2)
        assert pins_of(saved) == [(BODY.tolist(), BODY.tolist()), (ARM.tolist(), ARM.tolist())]
        np.testing.assert_array_equal(target, cage)  # a pin holds the picture where it is
        park_mouse(display, window)
        before = shot(display, tmp_path, "pins-placed")

        drag_point(display, window, window_pixel(view, ARM), (MOVED - ARM) * view["scale"])
        drag = viewer.wait_for("drag done frames=", 30)
        assert int(drag.split()[2].split("=")[1]) >= 2, drag  # the picture followed during the drag
        said = viewer.wait_for("status said moved pin 1; pins: ", 60)
        assert said.startswith("status said moved pin 1; pins: K ≤ 1 proven (no bound), fold-free"), said
        _, target, saved = wait_for_session(session, lambda c, t, v: not np.array_equal(t, c))
        assert pins_of(saved) == [(BODY.tolist(), BODY.tolist()), (ARM.tolist(), MOVED.tolist())]
        # Two pins: the similarity that places both, the body's pin where it was.
        residual, (a, b) = similarity_residual(cage, target)
        assert residual < 1e-6, residual
        assert abs(a * complex(*BODY) + b - complex(*BODY)) < 1e-6
        assert abs(a * complex(*ARM) + b - complex(*MOVED)) < 1e-6
        park_mouse(display, window)
        after = shot(display, tmp_path, "pins-dragged")
        assert changed_fraction(before, after) > 0.03, changed_fraction(before, after)

        xdotool(display, "key", "ctrl+z")
        assert (
            viewer.wait_for("status said undone:", 30)
            == "status said undone: moved 1 pin; moved 20 target points"
        )
        _, target, saved = wait_for_session(session, lambda c, t, v: np.array_equal(t, c))
        assert pins_of(saved) == [(BODY.tolist(), BODY.tolist()), (ARM.tolist(), ARM.tolist())]

        # The K slider: a click halfway between rigid and free asks K = 2 of the pins at their places.
        rigid = [float(v) for v in viewer_spot(viewer, "K rigid")]
        free = [float(v) for v in viewer_spot(viewer, "K free")]
        middle = 0.5 * (np.array(rigid) + free)
        xdotool(
            display, "mousemove", "--window", window, f"{middle[0]:.0f}", f"{middle[1]:.0f}", "click", "1"
        )
        said = viewer.wait_for("status said pins: K = ", 30)
        bound = float(said.split("K = ")[1].split(";")[0])
        assert 1.8 <= bound <= 2.2, said
        assert f"(bound {bound:g}), fold-free" in said, said
        _, target, saved = wait_for_session(session, lambda c, t, v: v.get("max_distortion") == bound)
        np.testing.assert_allclose(target, cage, atol=1e-6)  # pins at their places: nothing to move

        x, y = window_pixel(view, ARM)
        # Off the panel, a frame drawn first: imgui lets the canvas have the mouse from then on.
        xdotool(display, "mousemove", "--window", window, f"{x:.0f}", f"{y:.0f}")
        time.sleep(0.3)
        xdotool(display, "click", "3")
        said = viewer.wait_for("status said removed pin 1", 30)
        assert said.startswith("status said removed pin 1; pins: K ≤ 1 proven"), said
        _, target, saved = wait_for_session(session, lambda c, t, v: len(v.get("pins", [])) == 1)
        assert pins_of(saved) == [(BODY.tolist(), BODY.tolist())]
        np.testing.assert_allclose(target, cage, atol=1e-9)
        xdotool(display, "key", "ctrl+q")
        code, stderr = viewer.finish()
        assert code == 0, stderr
    finally:
        viewer.kill()
