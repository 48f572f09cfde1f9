"""``bench``'s launch rows: from ``python -m app`` to a picture that can be warped, in the real viewer.

Each run starts a viewer child in test mode on a private Xvfb server and times process start
to its ``drawn basis`` line: the first frame with the basis functions of the cage on screen, so a
drag deforms the picture at once.  Rows: the bundled demo with its basis functions not cached
(a first run) and cached (every later one), and a 24-megapixel JPEG photograph opened without
a cage (read, EXIF-oriented, a cage fitted to its subject, the texture uploaded).  The issue's
bounds are 3 s for the demo and 5 s for the photograph, on a quiet machine.

The warp start-up row (`warp_startup_row`, no window) times ``python -m app warp`` children in
turn: ``warp --help`` (process start to the command line parsed: the imports of every command)
and a warp of a small PNG, its basis cached (process start to the file written and the process
gone: imports, the mesher's compiled code loaded, meshing, the GL context, drawing, writing).
"""

from __future__ import annotations

import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from app.bench.xvfb import failure_details, viewer_lines

#: (width, height) of the launch row's photograph: 24 megapixels, and the quick smoke test's.
LAUNCH_PHOTO, QUICK_LAUNCH_PHOTO = (6000, 4000), (1200, 800)
#: Seconds one launch may take before it counts as failed.
LAUNCH_TIMEOUT = 120.0
#: (width, height) of the warp start-up row's picture.
STARTUP_PICTURE = (640, 480)


def warp_startup_row(repeats: int, quick: bool, failed: Callable[[str], Exception]) -> None:
    """Print the warp start-up row: medians of `repeats` turns (one if `quick`) of ``warp --help``
    and of a warp of a `STARTUP_PICTURE` PNG with its basis cached (one warp first fills the cache).

    Parameters
    ----------
    repeats : int
    quick : bool
    failed : callable
        Makes the exception that reports a failed run, from its message.
    """
    from app.bench.photos import photograph, write_starfish_drag

    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        _write_picture(folder / "photo.png", photograph(*STARTUP_PICTURE))
        write_starfish_drag(folder, *STARTUP_PICTURE)
        environment = dict(
            os.environ,
            TRANSFINITE_STATE_DIR=str(folder / "state"),
            TRANSFINITE_CACHE_DIR=str(folder / "cache"),
        )
        warp = ["warp", str(folder / "photo.png"), "--cage", str(folder / "cage.json")]
        warp += ["--target", str(folder / "target.json"), "--output", str(folder / "out.png")]
        _timed_run(warp, environment, failed)  # fills the basis cache
        helps, warps = [], []
        for _ in range(1 if quick else repeats):
            helps.append(_timed_run(["warp", "--help"], environment, failed))
            warps.append(_timed_run(warp, environment, failed))
    width, height = STARTUP_PICTURE
    print(f"warp start-up, {width}x{height} PNG, basis cached (process start to ...)")
    for label, times in (("the command line parsed (warp --help)", helps), ("the file written", warps)):
        turns = ", ".join(f"{t:.2f}" for t in times)
        print(f"  {label:<40} {statistics.median(times):6.2f} s (runs {turns})")
    print()


def _write_picture(path: Path, image) -> None:
    import cv2

    cv2.imwrite(str(path), image)


def _timed_run(arguments: list[str], environment: dict, failed) -> float:
    """Seconds from starting ``python -m app ARGUMENTS`` to its exit, which must be 0."""
    start = time.perf_counter()
    result = subprocess.run(
        [sys.executable, "-m", "app", *arguments],
        env=environment,
        capture_output=True,
        text=True,
        timeout=LAUNCH_TIMEOUT,
    )
    seconds = time.perf_counter() - start
    if result.returncode != 0:
        errors = result.stderr.strip().splitlines()[-10:] or ["(no output on stderr)"]
        details = "\n".join(f"    {line}" for line in errors)
        raise failed(
            f"python -m app {' '.join(arguments)} failed with exit code {result.returncode}:\n{details}"
        )
    return seconds


def launch_rows(
    repeats: int, quick: bool, started_xvfb: Callable, failed: Callable[[str], Exception]
) -> None:
    """Print the launch rows: the median of `repeats` runs each (one at small sizes if `quick`).

    Parameters
    ----------
    repeats : int
    quick : bool
    started_xvfb : callable
        ``started_xvfb(what)`` -> (server process, display name).
    failed : callable
        Makes the exception that reports a failed row, from its message.
    """
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        photo, (width, height) = folder / "photo.jpg", QUICK_LAUNCH_PHOTO if quick else LAUNCH_PHOTO
        _write_photo(photo, (width, height))
        server, display = started_xvfb("the viewer launch")
        try:
            print("viewer launch to a warpable picture (process start to the basis drawn, Xvfb 1280x1024)")
            environment = dict(os.environ, DISPLAY=display, TRANSFINITE_VIEWER_TEST="1")
            runs = 1 if quick else repeats
            rows = [
                ("demo, basis not cached", ["demo", "starfish", "--fresh"], "fresh"),
                ("demo, basis cached", ["demo", "starfish"], "shared"),
                (f"{width}x{height} JPEG, cage fitted", ["view", str(photo), "--fresh"], "fresh"),
            ]
            for row, (label, arguments, cache) in enumerate(rows):
                times = []
                for turn in range(runs):
                    state = folder / f"state-{row}-{turn}"
                    cached = folder / ("cache" if cache == "shared" else f"cache-{row}-{turn}")
                    if cache == "shared" and turn == 0:
                        _launch(arguments, environment, state, cached, failed)  # fills the cache
                    times.append(_launch(arguments, environment, state, cached, failed))
                turns = ", ".join(f"{t:.2f}" for t in times)
                print(f"  {label:<40} {statistics.median(times):6.2f} s (runs {turns})")
        finally:
            server.terminate()
            server.wait(timeout=10)
    print()


def _write_photo(path: Path, size: tuple[int, int]) -> None:
    """A JPEG like a photograph (soft discs, grain) of `size` (width, height), seed 5."""
    import cv2

    from app.bench.photos import photograph

    image = photograph(*size)
    cv2.imwrite(str(path), image, [cv2.IMWRITE_JPEG_QUALITY, 90])


def _launch(arguments: list[str], environment: dict, state: Path, cache: Path, failed) -> float:
    """Seconds from starting ``python -m app ARGUMENTS`` to its ``drawn basis`` line (the first frame
    with the basis functions on screen); the viewer then quits."""
    environment = dict(environment, TRANSFINITE_STATE_DIR=str(state), TRANSFINITE_CACHE_DIR=str(cache))
    start = time.perf_counter()
    child = subprocess.Popen(
        [sys.executable, "-m", "app", *arguments],
        env=environment,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    seconds = None

    def basis(line: str) -> bool:
        nonlocal seconds
        if line.startswith("drawn basis "):
            seconds = time.perf_counter() - start
            child.send_signal(signal.SIGTERM)  # saves and quits
        return seconds is not None

    seen = viewer_lines(child, LAUNCH_TIMEOUT, basis)
    if seconds is None:
        details = failure_details(child, seen, 10)
        raise failed(f"the viewer launch ({' '.join(arguments)}) drew no basis:\n{details}")
    return seconds
