"""Fold-free in the real viewer window under Xvfb (xdotool input): a strong drag of the starfish
demo folds the plain map and the status line says so; "B" switches fold-free on, the status line
says proven and the mesh drawn has no folded triangle; the session keeps it; Ctrl+Z takes it back.

Xvfb and xdotool are required: without them this test fails, it never skips.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
from support.fold_free_checks import ASSETS, STRONG
from support.paths import ROOT
from support.viewer_harness import (
    ViewerProcess,
    drag_point,
    start_xvfb,
    wait_for_session,
    window_pixel,
    xdotool,
)

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def display():
    process, name = start_xvfb()
    yield name
    process.terminate()
    process.wait(timeout=10)


def test_fold_free_on_a_strong_drag_is_proven_and_draws_no_folded_triangle(display, tmp_path):
    env = {
        **os.environ,
        "DISPLAY": display,
        "TRANSFINITE_CACHE_DIR": str(tmp_path / "cache"),
        "TRANSFINITE_STATE_DIR": str(tmp_path / "state"),
    }
    cage = np.array(json.loads((ASSETS / "starfish.cage.json").read_text())["control_points"], dtype=float)
    view = {"scale": 1.0, "offset": [450.0, 250.0]}
    session = tmp_path / "starfish.json"
    value = {
        "image": str(ASSETS / "starfish.png"),
        "cage": {"control_points": cage.tolist()},
        "target": {"control_points": cage.tolist()},
        "kernel": "poisson",
        "view": view,
    }
    session.write_text(json.dumps(value))
    viewer = ViewerProcess(["view", "--session", str(session)], env, ROOT)
    try:
        window = viewer.wait_for("ready window=", 30).split("=")[1]
        viewer.wait_for("basis ", 60)
        assert (
            viewer.wait_for("status check fold-free, proven", 60) == "status check fold-free, proven (σ₂ ≥ 1)"
        )
        xdotool(display, "windowfocus", "--sync", window)
        index, shift = STRONG
        drag_point(display, window, window_pixel(view, cage[index]), shift * view["scale"])
        # The plain map folds: the proof fails and the mesh has folded triangles.
        assert viewer.wait_for("status check folds", 60) == "status check folds near the marked spots"
        xdotool(display, "key", "b")
        proven = viewer.wait_for("status check fold-free, proven", 60)
        sigma = float(proven.split("≥ ")[1].rstrip(")"))
        assert sigma > 0, proven
        drawn = viewer.wait_for("fold-free drawn", 30)
        assert drawn == "fold-free drawn folded=0", drawn
        _, target, saved = wait_for_session(session, lambda c, t, v: v.get("fold_free") is True)
        np.testing.assert_allclose(target[index] - cage[index], shift, atol=1.5)
        xdotool(display, "key", "ctrl+z")
        assert viewer.wait_for("fold-free off", 30).startswith("fold-free off folded=")
        # The plain map's check is kept from before B: said again at once, without a new proof.
        checks = [line for line in viewer.lines if line.startswith(("status check", "check "))]
        assert checks[-2:] == ["check reused fold_free=False", "status check folds near the marked spots"]
        wait_for_session(session, lambda c, t, v: "fold_free" not in v)
        xdotool(display, "key", "ctrl+q")
        code, stderr = viewer.finish()
        assert code == 0, stderr
    finally:
        viewer.kill()
