"""Fold-free in the real viewer window under Xvfb (xdotool input): a strong drag of the starfish
demo folds the plain map and the status line says so; "B" switches fold-free on, the status line
says proven and the mesh drawn has no folded triangle; the session keeps it; Ctrl+Z takes it back.
A hard drag with fold-free on draws no turned-over triangle in any frame, its boundary on the target
curve, within the frame time (against the plain drag's), and is proven soon after the release.

Xvfb and xdotool are required: without them this test fails, it never skips.
"""

from __future__ import annotations

import json
import re
import signal

import numpy as np
import pytest
from support.fold_free_checks import STRONG
from support.paths import ROOT
from support.viewer_harness import (
    STARFISH_CAGE,
    ViewerProcess,
    drag_point,
    starfish_session,
    start_xvfb,
    viewer_environment,
    wait_for_session,
    window_pixel,
    xdotool,
)

from app.bench.fold_free_drag import drag_moves

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def display():
    process, name = start_xvfb()
    yield name
    process.terminate()
    process.wait(timeout=10)


def test_fold_free_on_a_strong_drag_is_proven_and_draws_no_folded_triangle(display, tmp_path):
    env = viewer_environment(display, tmp_path)
    cage = STARFISH_CAGE
    view = {"scale": 1.0, "offset": [450.0, 250.0]}
    session = tmp_path / "starfish.json"
    starfish_session(session, view)
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
        # At once the mesh map, proven a bijection (`app.viewer.fold_free_frames`); the background
        # worker's fold-free map after it (`core.fold_free_deform`: proven on the mesh, with the σ₂
        # of its triangles).
        drawn = viewer.wait_for("fold-free drawn", 30)
        assert drawn == "fold-free drawn folded=0", drawn
        # (The worker's map may come first where it is as quick as the frames' own proof.)
        proven = viewer.wait_for("status check fold-free on the mesh, proven", 30)
        if proven.startswith("status check fold-free on the mesh, proven; "):
            proven = viewer.wait_for("status check fold-free on the mesh, proven (σ₂ ≥ ", 60)
        sigma = float(proven.split("≥ ")[1].rstrip(")"))
        assert sigma > 0, proven
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


#: Limits of the hard drag with fold-free on, for a loaded CI (the bench's row measures the issue's
#: figures on a quiet machine): its median frame against the plain drag's in the same window (the
#: issue's 2x; with 2 cores shared by a load of ~10 the two medians swung from 12 to 35 ms between
#: runs, so 3x here) and in ms (the issue's 60 ms a frame); the share of its frames drawn with the
#: boundary on the target curve and the farthest a boundary vertex was drawn from it (px): in the
#: bench's eight runs at load 9-17, 276 of 290 frames, the worst run 15 of 20 and 2.3 px (every frame
#: given the time: tests/app/viewer/test_fold_free_frames.py); the time from the release to "proven"
#: on the status line (the issue's 1 s; 0.03-0.3 s in those runs, 0.6-2.4 s before the last frame
#: was drawn on the curve).
RATIO_LIMIT = 3.0
FRAME_LIMIT_MS = 60.0
ON_TARGET_SHARE = 0.75
LAG_LIMIT_PX = 3.0
PROOF_LIMIT_MS = 1000.0


def test_a_hard_drag_with_fold_free_on_draws_no_turned_over_triangle_and_is_proven_after_release(
    display, tmp_path
):
    """The demo in a 1366x768 window, `STRONG` replayed through the mouse's input path (its plain map
    turns 249 of the default mesh's triangles over) out and back with fold-free off, then out again
    with it on (`app.bench.fold_free_drag.drag_moves`, as the bench's row): --stats counts the
    fold-free frames drawn during the drag, the most turned-over triangles one drew (0), those on
    the target curve, their median time against the plain drag's, and the time from the release to
    the status line's proof."""
    env = viewer_environment(display, tmp_path)
    cage = STARFISH_CAGE
    session = tmp_path / "starfish.json"
    starfish_session(session, {"scale": 1.0, "offset": [350.0, 120.0]})
    index, shift = STRONG
    script = tmp_path / "drag.json"
    script.write_text(json.dumps({"moves": drag_moves(index, cage[index], cage[index] + shift, 2.0)}))
    arguments = ["demo", "starfish", "--session", str(session), "--script", str(script), "--stats"]
    viewer = ViewerProcess(arguments, env, ROOT, window_size=(1366, 768))
    try:
        viewer.wait_for("basis ", 60)
        viewer.wait_for("script done", 60)
        # The proof of a quick release may come before the script's end.
        proven = next((line for line in viewer.lines if line.startswith("proven after release ms=")), None)
        proven = proven or viewer.wait_for("proven after release ms=", 30)
        viewer.process.send_signal(signal.SIGTERM)  # quits cleanly, printing --stats
        code, stderr = viewer.finish()
        assert code == 0, stderr
    finally:
        viewer.kill()
    stats = next(line for line in viewer.lines if line.startswith("frames="))
    figures = dict(item.split("=", 1) for item in stats.split())
    frames = int(figures["fold_free_drag_frames"])
    assert frames >= 10, stats
    assert int(figures["max_folded_drawn"]) == 0, stats
    assert int(figures["fold_free_drag_frames_on_target"]) >= ON_TARGET_SHARE * frames, stats
    assert float(figures["max_boundary_lag_px"]) <= LAG_LIMIT_PX, stats
    fold_free, plain = (
        float(figures[key]) for key in ("median_fold_free_drag_frame_ms", "median_plain_drag_frame_ms")
    )
    assert 0 < fold_free <= min(FRAME_LIMIT_MS, RATIO_LIMIT * plain), stats
    assert float(figures["proven_after_release_ms"]) <= PROOF_LIMIT_MS, stats
    assert re.fullmatch(r"proven after release ms=\d+", proven), proven
    said = [line for line in viewer.lines if line.startswith("status check ")]
    assert any(line.startswith("status check fold-free on the mesh, proven") for line in said), said
    _, target, _ = wait_for_session(session, lambda c, t, v: v.get("fold_free") is True)
    np.testing.assert_allclose(target[index] - cage[index], shift, atol=1.5)
