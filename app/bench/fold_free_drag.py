"""The viewer's fold-free drag frame beside the plain one: one viewer, one hard drag twice.

A child ``python -m app demo starfish`` at the default mesh, in a 1366x768 window on a private
Xvfb server, replays a hard drag (point 5 pulled 60 px up and left, across its arm's root: the
plain map turns 249 triangles over): out and back with fold-free off, then (fold-free switched on
at rest by the script's ``"fold_free"``, and a pause for the background check) out again with it
on, and reports on exit (``--stats``) the median frame of each, the
most turned-over triangles a fold-free frame drew, and the time from the last release, at the hard
pose, to a proof on the status line (`app.viewer.milestones`).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

from app.bench.xvfb import failure_details, viewer_lines

#: The dragged point and how far: its plain map turns 249 of the 12,155 triangles over at the end.
POINT, OFFSET = 5, (-42.43, -42.43)
#: The window, as the issue's laptop screen.
WINDOW = (1366, 768)
#: Seconds each of the four moves lasts, and at most the whole run.
MOVE_SECONDS = 1.5
TIMEOUT = 600
#: Seconds of the move that switches fold-free on at rest (the point stays), and from its start to
#: the fold-free drag.
SWITCH_SECONDS, SWITCH_PAUSE = 0.05, 1.0
#: Seconds after the script for the proof after the last release.
PROOF_WAIT = 5.0


def drag_moves(point: int, start, out, move_seconds: float) -> list[dict]:
    """A demo script's moves (`app.viewer.demos`) of control point `point` from `start` (2,) to `out`
    (2,) and back with fold-free off, fold-free switched on at rest, and after `SWITCH_PAUSE` (the
    background check of the rest pose done, so that it does not share the CPU with the drag's
    frames) out again with it on; each drag lasting `move_seconds`."""
    start, out = [float(v) for v in start], [float(v) for v in out]
    moves = [
        (0.0, move_seconds, out, False),
        (move_seconds, move_seconds, start, False),
        (2.0 * move_seconds, SWITCH_SECONDS, start, True),
        (2.0 * move_seconds + SWITCH_PAUSE, move_seconds, out, True),
    ]
    return [
        {"at": at, "duration": duration, "point": point, "to": to, "fold_free": fold_free}
        for at, duration, to, fold_free in moves
    ]


def fold_free_drag_row(step_failed: type[Exception], move_seconds: float = MOVE_SECONDS) -> None:
    """Print the row, each move lasting `move_seconds`; `step_failed` (`app.bench.table.StepFailed`)
    names a failed child."""
    title = "viewer fold-free drag frame"
    if shutil.which("Xvfb") is None:
        print(f"{title}: skipped: no Xvfb (apt-get install xvfb)")
        return
    from app.bench.xvfb import start_xvfb
    from app.io.files import read_cage
    from app.viewer.demos import demo_files

    cage = read_cage(demo_files("starfish").cage)
    moves = drag_moves(POINT, cage[POINT], cage[POINT] + OFFSET, move_seconds)
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        script = folder / "drag.json"
        script.write_text(json.dumps({"moves": moves}))
        try:
            server, display = start_xvfb(WINDOW)
        except RuntimeError as error:
            raise step_failed(f"the {title} failed: {error}") from None
        try:
            stats = _run(folder, display, script, step_failed)
        finally:
            server.terminate()
            server.wait(timeout=10)
    plain, fold_free = (
        float(stats["median_plain_drag_frame_ms"]),
        float(stats["median_fold_free_drag_frame_ms"]),
    )
    print(
        f"{title} (Xvfb {WINDOW[0]}x{WINDOW[1]}, one viewer: point {POINT} dragged by {OFFSET} px and back "
        "plain, then out fold-free; median over frames)"
    )
    print(
        f"  {int(stats['vertices']):>9,} vertices: plain {plain:.1f} ms, fold-free {fold_free:.1f} ms "
        f"({fold_free / max(plain, 1e-9):.2f}x) over {stats['fold_free_drag_frames']} frames "
        f"({stats['fold_free_drag_frames_on_target']} on the target curve, the others at most "
        f"{stats['max_boundary_lag_px']} px behind it; slowest {stats['max_fold_free_drag_frame_ms']} ms), "
        f"at most {stats['max_folded_drawn']} turned-over triangles drawn; "
        f"proven {stats['proven_after_release_ms']} ms after the release"
    )
    print()


def _run(folder: Path, display: str, script: Path, step_failed) -> dict:
    """Run the demo viewer on `script`; the --stats figures and the mesh's vertices."""
    environment = dict(
        os.environ, DISPLAY=display, TRANSFINITE_VIEWER_TEST="1", TRANSFINITE_STATE_DIR=str(folder / "state")
    )
    command = [sys.executable, "-m", "app", "demo", "starfish", "--script", str(script)]
    command += [
        "--session",
        str(folder / "session.json"),
        "--stats",
        "--window-size",
        "{}x{}".format(*WINDOW),
    ]
    child = subprocess.Popen(
        command, env=environment, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    vertices, stopper, proven = None, None, False

    def milestone(line: str) -> bool:
        nonlocal vertices, stopper, proven
        if line.startswith("basis "):
            vertices = re.search(r"vertices=(\d+)", line).group(1)
        # Quit (SIGTERM: cleanly, printing --stats) once the script is done and its fold-free
        # release proven, whichever comes last (a quick release's proof may come before the
        # script's end), or `PROOF_WAIT` after the script if no proof comes.
        if line.startswith("proven after release"):
            proven = True
            if stopper is not None:
                stopper.cancel()
                child.send_signal(signal.SIGTERM)
        elif line.startswith("script done"):
            stopper = threading.Timer(0.0 if proven else PROOF_WAIT, child.send_signal, (signal.SIGTERM,))
            stopper.start()
        return False

    try:
        lines = viewer_lines(child, TIMEOUT, milestone)
    finally:
        if stopper is not None:
            stopper.cancel()
    stats = [line for line in lines if line.startswith("frames=")]
    if child.returncode != 0 or not stats or vertices is None:
        details = failure_details(child, lines, 20)
        raise step_failed(
            f"the viewer fold-free drag frame failed with exit code {child.returncode}:\n{details}"
        )
    figures = dict(item.split("=", 1) for item in stats[-1].split())
    figures["vertices"] = vertices
    return figures
