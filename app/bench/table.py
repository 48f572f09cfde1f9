"""``python -m app bench``: the performance table on this machine.

Every row is the median of repeated runs in this one process, next to a baseline
measured in the same process (the plain numpy reference of `core.newton.reference`, and
the finite-element harmonic solve the paper compares against), so that ratios
stay meaningful on a shared, noisy machine.  The 1,000,000-point memory run,
the 4K warp and the photograph rows (`app.bench.photos`) run as child processes,
to measure their own peak memory and their whole time from process start.  The
drag frame is measured in the real viewer: a child ``python -m app demo starfish``
in a window on a private Xvfb server, replaying a scripted drag of one control
point through the mouse's input path, and its ``--stats`` line
(``median_drag_frame_ms``) read on exit; the launch rows (`app.bench.launch`) time such
children from their start to a picture that can be warped.  The GIF export row times the same demo's
Ctrl+E to a .gif (sent with xdotool; its ``exported`` milestone) against ``animate``
of the session the viewer saved, in turn.
"""

from __future__ import annotations

import argparse
import json
import os
import queue
import re
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import warnings
from pathlib import Path

import numpy as np

import core
from app.bench.launch import launch_rows, warp_startup_row
from app.bench.photos import (
    PHOTO_SIZES,
    QUICK_ANIMATION_SIZE,
    QUICK_SIZE,
    animation_row,
    photo_rows,
    write_starfish_drag,
)
from app.bench.timing import edge_for_vertices, median_time, print_head
from app.bench.xvfb import failure_details, viewer_lines
from app.console import EXIT_ENVIRONMENT, EXIT_OK, ProgressBar
from core import GRADIENTS_COMPILE_MESSAGE as GRADIENTS_COMPILING
from core import examples
from core import load_compiled_integrals as load_compiled

# The paper's Fig. 7 setting: a 12-point domain, N = 100 n samples, 26,000 points.
SAMPLES_PER_SEGMENT = 100
SCALE = 1000.0  # the example domain in pixels
#: The kernel whose gradients are timed against its values (the default point kernel).
GRADIENT_KERNEL = "inverse-cube-mean"
#: How many of a failed child's last stderr lines `run_child` shows.
CHILD_ERROR_LINES = 20
#: Mesh sizes of the viewer's drag-frame rows: the viewer's default, and a dense mesh.
DRAG_VERTICES = (6_000, 400_000)
#: Seconds the scripted drag lasts (every frame of it is drawn while the point is dragged).
DRAG_SECONDS = 4.0
#: Seconds before each timed run of the FEM comparison (see `_alternating_medians`).
BLAS_SETTLE = 0.3
#: Seconds each solve of an FEM-comparison row runs for at least, in all (`_alternating_medians`).
ROW_SECONDS = 1.5
#: Turns `_alternating_medians` takes at most.
MAX_REPEATS = 15
#: Seconds a viewer child may take, its precompute included (400k vertices: minutes).
DRAG_TIMEOUT = 900
#: Turns of the GIF export row: the viewer's export and ``animate``'s, in turn (`_export_gif`).
EXPORT_REPEATS = 3
#: Frames per second of the GIF export row: the viewer's and ``animate``'s default (220 frames), and
#: the quick smoke test's (8 frames, one a second of the 7.3 s: the same commands and checks, with
#: ~10 CPU-s less drawing and encoding).
EXPORT_FPS, QUICK_EXPORT_FPS = 30.0, 1.0
#: Seconds the export row waits for one line of the viewer (its start and precompute included).
EXPORT_TIMEOUT = 300


def run_bench(args: argparse.Namespace) -> int:
    """The ``bench`` command (arguments: `app.commands.cli`): print the table; returns the exit code.

    A row measured in a child process that fails is reported with the child's own
    error output, the other rows still run, and the exit code is then 1.
    """
    repeats = args.repeats
    curve = core.ClosedBSpline(examples.blob() * SCALE)
    sizes = (500,) if args.quick else (26_000, 200_000)
    _warm_up(curve)
    print(f"transfinite-warp bench: {os.cpu_count()} cores, numba threads {_threads()}")
    print(f"domain: 12-point blob, N = {SAMPLES_PER_SEGMENT * curve.n} samples; median of {repeats}\n")
    _point_kernels(curve, sizes, repeats, args.quick)
    if not args.skip_fem:
        vertices = (2_000,) if args.quick else (10_000, 100_000, 300_000)
        if args.large:
            vertices += (1_000_000,)
        # Quick: each solve once, not again and again for ROW_SECONDS.
        _fem_comparison(curve, vertices, 1 if args.quick else repeats, 0.0 if args.quick else ROW_SECONDS)
    if not args.skip_fold_free:
        from app.bench.fold_free import fold_free_rows, large_cage_row
        from app.bench.fold_free_held_out import held_out_rows

        fold_free_rows(
            curve, 1 if args.quick else repeats, _forget_densities, (2_000,) if args.quick else None
        )
        large_cage_row(1, 40) if args.quick else large_cage_row(repeats)
        held_out_rows(_forget_densities, args.quick)
    if not args.skip_pins:
        from app.bench.pins import pin_rows

        pin_rows((16,), 2, 1) if args.quick else pin_rows()
    if not args.skip_mesher:
        from app.bench.mesher import LEAST_REPEATS, mesher_rows

        mesher_rows(curve, 1 if args.quick else max(repeats, LEAST_REPEATS), (2_000,) if args.quick else None)
    children = []
    if not args.skip_memory:
        children.append(lambda: _memory(curve, 20_000 if args.quick else 1_000_000))
    if not args.skip_warp:
        children.append(lambda: _warp_4k((640, 360) if args.quick else (3840, 2160)))
    if not args.skip_photos:
        children.append(
            lambda: (
                photo_rows((QUICK_SIZE,), run_child, 1) if args.quick else photo_rows(PHOTO_SIZES, run_child)
            )
        )
        animation = (QUICK_ANIMATION_SIZE, 0.25, 1) if args.quick else ()
        children.append(lambda: animation_row(run_child, *animation))
    if not args.skip_drag:
        from app.bench import fold_free_drag

        children.append(
            lambda: _drag_frames(DRAG_VERTICES[:1], 1.0) if args.quick else _drag_frames(DRAG_VERTICES)
        )
        children.append(
            lambda: (
                fold_free_drag.fold_free_drag_row(StepFailed, 0.5)
                if args.quick
                else fold_free_drag.fold_free_drag_row(StepFailed)
            )
        )
    if not args.skip_launch:
        children.append(lambda: warp_startup_row(args.repeats, args.quick, StepFailed))
        children.append(lambda: launch_rows(args.repeats, args.quick, _started_xvfb, StepFailed))
    if not args.skip_export:
        children.append(
            lambda: (
                _export_gif(1, QUICK_EXPORT_FPS) if args.quick else _export_gif(EXPORT_REPEATS, EXPORT_FPS)
            )
        )
    code = EXIT_OK
    for child in children:
        try:
            child()
        except StepFailed as error:
            print(f"bench: {error}", file=sys.stderr, flush=True)
            code = EXIT_ENVIRONMENT
    return code


class StepFailed(RuntimeError):
    """A row measured in a child process failed; the message holds the child's error output."""


def run_child(command: list[str], what: str, **kwargs) -> subprocess.CompletedProcess:
    """Run `command` (a child process measuring the row `what`) and capture its output.

    Returns
    -------
    subprocess.CompletedProcess
        With ``stdout`` and ``stderr`` as text.

    Raises
    ------
    StepFailed
        If the child exits with a non-zero code: what failed, the code and the
        child's stderr (its last lines), so the real error is on the screen.
    """
    result = subprocess.run(command, capture_output=True, text=True, **kwargs)
    if result.returncode != 0:
        lines = result.stderr.strip().splitlines()[-CHILD_ERROR_LINES:] or ["(no output on stderr)"]
        details = "\n".join(f"    {line}" for line in lines)
        raise StepFailed(f"{what} failed with exit code {result.returncode}:\n{details}")
    return result


def _threads() -> int:
    import numba

    return numba.get_num_threads()


def _warm_up(curve: core.ClosedBSpline) -> None:
    """Compile (or load from numba's cache) every kernel before timing."""
    with ProgressBar(GRADIENTS_COMPILING, announce=True) as compiling:
        core.compile_solver(compiling, gradients=True)
    x = _points(curve, 50, seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name in core.KERNELS:
            if name not in ("wachspress", "laplace"):
                core.basis_functions(curve, x, name)
        core.basis_gradients(curve, x, GRADIENT_KERNEL)
        core.pgw_basis(curve, x[:5])
    if not load_compiled():
        print("note: poisson's compiled loops are not in numba's cache here: it runs as numpy batches")


def _points(curve: core.ClosedBSpline, count: int, seed: int) -> np.ndarray:
    """`count` uniformly random points in the domain, shape (count, 2)."""
    rng = np.random.default_rng(seed)
    low, high = curve.control_points.min(axis=0), curve.control_points.max(axis=0)
    found = np.zeros((0, 2))
    while found.shape[0] < count:
        x = rng.uniform(low, high, size=(2 * count, 2))
        found = np.vstack([found, x[curve.contains(x)]])
    return found[:count]


def _alternating_medians(functions, repeats: int, least_seconds: float = 0.0) -> list[float]:
    """The median seconds of each of `functions`, run in turn at least `repeats` times.

    Each run waits BLAS_SETTLE seconds first: OpenBLAS's worker threads busy-wait
    for a while after a call (the FEM solve's sparse factorisation calls BLAS), and
    on a 2-core machine whichever solve came next was timed against them (the
    transfinite solve measured 1.2-1.4x slower straight after the FEM solve).
    Alternating spreads the machine's drifts over both.  Short runs go on until each
    function has run for `least_seconds` in all (at most MAX_REPEATS turns): the
    median of a tenth of a second measured three times moved by 20 % between runs of
    the bench on a shared machine.
    """
    times = [[] for _ in functions]
    while len(times[0]) < repeats or (
        min(sum(spent) for spent in times) < least_seconds and len(times[0]) < MAX_REPEATS
    ):
        for function, spent in zip(functions, times, strict=True):
            time.sleep(BLAS_SETTLE)
            start = time.perf_counter()
            function()
            spent.append(time.perf_counter() - start)
    return [statistics.median(spent) for spent in times]


def _row(name: str, count: int, samples: int, seconds: float, newton: str) -> None:
    rate = 1e6 * seconds / count
    print(f"{name:<28} {count:>10,} {samples:>10,} {seconds:>9.3f} {rate:>9.2f} {newton:>15}")


def _point_kernels(curve, sizes, repeats, quick) -> None:
    print("point kernels (basis functions G at random interior points)")
    header = f"{'kernel':<28} {'points M':>10} {'samples N':>10} {'seconds':>9} {'us/point':>9} "
    header += f"{'Newton med/max':>15}"
    print_head(header)
    samples = SAMPLES_PER_SEGMENT * curve.n
    rows = [(name, sizes[0]) for name in core.KERNELS if name not in ("wachspress", "laplace")]
    rows[1:1] = [("harmonic-like", size) for size in sizes[1:]]
    default_rate = None
    for name, count in rows:
        x = _points(curve, count, seed=1)

        def run(x=x, name=name):
            _forget_densities()  # poisson's timings include its density solve
            return core.basis_functions(curve, x, name, return_report=True)

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            seconds, (_, report) = median_time(run, repeats)
        iterations = report.iterations
        newton = f"{int(np.median(iterations))} / {iterations.max()}" if iterations.max() else "-"
        _row(name, count, samples, seconds, newton)
        if name == "harmonic-like" and count == sizes[0]:
            default_rate = seconds / count
    count = min(sizes[0], 2_000)
    x = _points(curve, count, seed=1)
    seconds, _ = median_time(lambda: core.pgw_basis(curve, x), repeats)
    _row("pgw (comparison, lines)", count, samples // 2, seconds, "-")
    pgw_rate = seconds / count
    count = min(sizes[0], 200 if quick else 1_000)
    x = _points(curve, count, seed=1)
    # The baseline solves only farther than a few sample spacings from the boundary.
    from core import distance_to_curve, reference_kernel

    x = x[distance_to_curve(curve.piecewise_polynomial(), x) > 0.02 * curve.diameter]
    boundary = curve.sample(SAMPLES_PER_SEGMENT)
    seconds, _ = median_time(lambda: reference_kernel(boundary, x), repeats)
    reference_rate = seconds / x.shape[0]
    _row("numpy reference (baseline)", x.shape[0], samples, seconds, "-")
    gradient_ratio = _gradients(curve, sizes[0], samples, repeats)
    print(
        f"\nharmonic-like vs the numpy reference: {reference_rate / default_rate:.1f}x faster; "
        f"vs PGW: {pgw_rate / default_rate:.1f}x faster (per point, same process)"
    )
    print(
        f"gradients grad G vs values G ({GRADIENT_KERNEL}, same points, same process, median of "
        f"alternating runs): {gradient_ratio:.2f}x the values' time (goal: at most 2x)\n"
    )


def _gradients(curve, count, samples, repeats) -> float:
    """Time `core.basis_gradients` and `core.basis_functions` on the same points, alternating;
    print the gradients' row and return the ratio of the medians."""
    x = _points(curve, count, seed=1)
    values, gradients = [], []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for _ in range(max(repeats, 3)):
            for times, function in ((values, core.basis_functions), (gradients, core.basis_gradients)):
                start = time.perf_counter()
                function(curve, x, GRADIENT_KERNEL)
                times.append(time.perf_counter() - start)
    seconds = statistics.median(gradients)
    _row(f"gradients ({GRADIENT_KERNEL})", count, samples, seconds, "-")
    return seconds / statistics.median(values)


def _fem_comparison(curve, vertices, repeats: int, least_seconds: float = ROW_SECONDS) -> None:
    print(
        "the default (poisson: harmonic coordinates by a boundary integral, its density solve included; "
        "'solve cached': the same cage's densities already solved) and harmonic-like vs finite-element "
        "harmonic on the same mesh (Fig. 7 right)"
    )
    header = f"{'vertices V':>11} {'mesh s':>8} {'FEM s':>8} {'poisson s':>10} {'FEM / poisson':>14}"
    header += f" {'solve cached s':>15} {'harmonic-like s':>16} {'FEM / h-like':>13} {'Newton med':>11}"
    print_head(header)
    for count in vertices:
        max_edge = edge_for_vertices(curve.area, count)
        start = time.perf_counter()
        mesh = core.triangulate(curve, max_edge=max_edge)
        meshing = time.perf_counter() - start

        def fem_solve(mesh=mesh):
            return core.harmonic_basis(curve, mesh)

        def default(mesh=mesh):
            _forget_densities()
            return core.mesh_basis_functions(curve, mesh, "poisson", cache=False)

        def evaluation(mesh=mesh):  # the densities of the cage already solved (by `default`)
            return core.mesh_basis_functions(curve, mesh, "poisson", cache=False)

        def transfinite(mesh=mesh):
            return core.mesh_basis_functions(curve, mesh, "harmonic-like", cache=False)

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fem, ours, evaluated, newton = _alternating_medians(
                (fem_solve, default, evaluation, transfinite), repeats, least_seconds
            )
            # The same solve, untimed, for its per-vertex Newton iterations on the N samples.
            _, report = core.basis_functions(
                curve, mesh.vertices[mesh.interior], "harmonic-like", return_report=True
            )
        row = f"{mesh.vertices.shape[0]:>11,} {meshing:>8.2f} {fem:>8.3f} {ours:>10.3f} {fem / ours:>14.2f}"
        row += f" {evaluated:>15.3f}"
        print(f"{row} {newton:>16.3f} {fem / newton:>13.2f} {np.median(report.iterations):>11.0f}")
    print()


def _forget_densities() -> None:
    """Empty the in-process cache of `poisson`'s densities, so that a timed run solves again."""
    from core import solved_densities

    solved_densities.cache_clear()


_MEMORY_CHILD = """
import sys, time, warnings
import numpy as np
import core
from core.curves import examples
curve = core.ClosedBSpline(examples.blob() * {scale})
core.basis_functions(curve, [[500.0, 300.0]], "harmonic-like")
rng = np.random.default_rng(2)
batches, found = [], 0
while found < {count}:  # in batches, so that making the points does not set the peak
    batch = rng.uniform(curve.control_points.min(0), curve.control_points.max(0), size=(200_000, 2))
    batches.append(batch[curve.contains(batch)])
    found += len(batches[-1])
x = np.concatenate(batches)[:{count}]
del batches
def high_water():  # VmHWM in KiB; ru_maxrss would include the parent's forked copy
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1])
before = high_water()
start = time.perf_counter()
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    G = core.basis_functions(curve, x, "harmonic-like")
seconds = time.perf_counter() - start
peak = high_water()
print(seconds, before, peak, G.shape[0])
"""


def _memory(curve, count) -> None:
    code = _MEMORY_CHILD.format(scale=SCALE, count=count)
    result = run_child([sys.executable, "-c", code], f"the {count:,}-point memory run")
    seconds, before, peak, rows = result.stdout.split()
    print(
        f"{int(rows):,} points, harmonic-like: {float(seconds):.2f} s, peak memory of the whole process "
        f"{int(peak) / 1024:.0f} MiB (before the call {int(before) / 1024:.0f} MiB)\n"
    )


def _warp_4k(size) -> None:
    """`python -m app warp` on a generated image, from process start to the PNG written."""
    import cv2

    width, height = size
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        rng = np.random.default_rng(3)
        image = np.zeros((height, width, 3), np.uint8)
        image[:] = (40, 60, 90)
        for _ in range(200):
            centre = (int(rng.integers(0, width)), int(rng.integers(0, height)))
            colour = tuple(int(c) for c in rng.integers(0, 255, 3))
            cv2.circle(image, centre, int(rng.integers(5, width // 20)), colour, -1, cv2.LINE_AA)
        cv2.imwrite(str(folder / "image.png"), image)
        write_starfish_drag(folder, width, height)
        environment = dict(os.environ, TRANSFINITE_CACHE_DIR=str(folder / "cache"))
        command = [
            sys.executable,
            "-m",
            "app",
            "warp",
            str(folder / "image.png"),
            "--cage",
            str(folder / "cage.json"),
            "--target",
            str(folder / "target.json"),
            "--output",
            str(folder / "out.png"),
        ]
        start = time.perf_counter()
        run_child(command, f"the {width}x{height} warp", env=environment)
        seconds = time.perf_counter() - start
        written = (folder / "out.png").stat().st_size
    print(
        f"warp {width}x{height} end to end (process start to PNG written, basis not cached): "
        f"{seconds:.2f} s ({written / 2**20:.1f} MiB PNG)"
    )


def _drag_frames(vertex_counts, seconds: float = DRAG_SECONDS) -> None:
    """The viewer's median drag frame at about each of `vertex_counts` vertices, under Xvfb."""
    if shutil.which("Xvfb") is None:
        print("viewer drag frame: skipped: no Xvfb (apt-get install xvfb)")
        return
    from app.io.files import read_cage
    from app.viewer.demos import demo_files
    from app.viewer.editing import default_max_edge

    files = demo_files("starfish")
    cage = read_cage(files.cage)
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        script = folder / "drag.json"
        # Point 0 (the top arm's tip) out and back: two moves, every frame a drag frame.
        out = (cage[0] + (60.0, 30.0)).tolist()
        moves = [
            {"at": 0.0, "duration": seconds / 2, "point": 0, "to": out},
            {"at": seconds / 2, "duration": seconds / 2, "point": 0, "to": cage[0].tolist()},
        ]
        script.write_text(json.dumps({"moves": moves}))
        server, display = _started_xvfb("the viewer drag frame")
        try:
            print(
                "viewer drag frame (Xvfb 1280x1024, scripted drag through the mouse path, median over frames)"
            )
            for count in vertex_counts:
                max_edge = default_max_edge(cage, count)
                vertices, preview, median = _drag_child(folder, display, script, max_edge, count)
                drawn = f", drawn through a {preview:,}-vertex preview" if preview else ""
                print(f"  {vertices:>9,} vertices (max edge {max_edge} px{drawn}): {median:7.1f} ms")
        finally:
            server.terminate()
            server.wait(timeout=10)
    print()


def _started_xvfb(what: str) -> tuple[subprocess.Popen, str]:
    """`app.bench.xvfb.start_xvfb` at 1280x1024, or `StepFailed` naming `what`."""
    from app.bench.xvfb import start_xvfb

    try:
        return start_xvfb((1280, 1024))
    except RuntimeError as error:
        raise StepFailed(f"{what} failed: {error}") from None


def _drag_child(
    folder: Path, display: str, script: Path, max_edge: float, count: int
) -> tuple[int, int, float]:
    """Run the demo viewer on `script` at `max_edge`; (vertices, preview vertices or 0, median drag
    frame in ms)."""
    environment = dict(
        os.environ,
        DISPLAY=display,
        TRANSFINITE_VIEWER_TEST="1",
        TRANSFINITE_STATE_DIR=str(folder / "state"),
    )
    session = folder / f"session-{count}.json"
    command = [sys.executable, "-m", "app", "demo", "starfish", "--script", str(script), "--session"]
    command += [str(session), "--max-edge", str(max_edge), "--stats"]
    what = f"the viewer drag frame at {count:,} vertices"
    child = subprocess.Popen(
        command, env=environment, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    vertices, preview = 0, 0

    def milestone(line: str) -> bool:
        nonlocal vertices, preview
        if line.startswith("basis "):
            vertices = int(re.search(r"vertices=(\d+)", line).group(1))
            preview = int(re.search(r"preview=(\d+)", line).group(1))
        if line.startswith("script done"):
            child.send_signal(signal.SIGTERM)  # quits cleanly, printing --stats
        return False

    lines = viewer_lines(child, DRAG_TIMEOUT, milestone)
    stats = [m for m in map(re.compile(r"frames=.*median_drag_frame_ms=([\d.]+)").match, lines) if m]
    if child.returncode != 0 or not stats or not vertices:
        details = failure_details(child, lines, CHILD_ERROR_LINES)
        raise StepFailed(f"{what} failed with exit code {child.returncode}:\n{details}")
    return vertices, preview, float(stats[-1].group(1))


def _export_gif(repeats: int, fps: float) -> None:
    """The viewer's GIF export of the starfish demo's animation at `fps` frames per second (Ctrl+E
    with ``--export``, under Xvfb: key press to the ``exported`` milestone) against ``animate`` of
    the session it saved (process start to exit, the basis read from the cache the viewer wrote),
    `repeats` turns each, in turn; prints both medians, their ratio, and whether the two GIFs are
    the same bytes."""
    if shutil.which("Xvfb") is None or shutil.which("xdotool") is None:
        print("viewer GIF export: skipped: needs Xvfb and xdotool (apt-get install xvfb xdotool)")
        return
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        session, movie, animated = folder / "session.json", folder / "viewer.gif", folder / "animate.gif"
        server, display = _started_xvfb("the viewer GIF export")
        environment = dict(
            os.environ,
            DISPLAY=display,
            TRANSFINITE_VIEWER_TEST="1",
            TRANSFINITE_STATE_DIR=str(folder / "state"),
            TRANSFINITE_CACHE_DIR=str(folder / "cache"),
        )
        # --play: the demo's keyframes (playing them until the export stops them).
        command = [sys.executable, "-m", "app", "demo", "starfish", "--play", "--session", str(session)]
        command += ["--fps", f"{fps:g}"]
        viewer = ViewerChild([*command, "--export", str(movie)], environment)
        try:
            window = viewer.wait_for("ready window=").split("=")[1]
            viewer.wait_for("basis ")
            key = ["xdotool", "mousemove", "--window", window, "20", "20", "key", "ctrl+e"]
            animate = [sys.executable, "-m", "app", "animate", str(session), "--output", str(animated)]
            animate += ["--fps", f"{fps:g}"]
            viewer_times, animate_times = [], []
            for _ in range(repeats):
                movie.unlink(missing_ok=True)
                start = time.perf_counter()
                run_child(key, "xdotool", env=environment)
                viewer.wait_for(f"exported {movie}")
                viewer_times.append(time.perf_counter() - start)
                animated.unlink(missing_ok=True)
                start = time.perf_counter()
                run_child(animate, "animate of the starfish session", env=environment)
                animate_times.append(time.perf_counter() - start)
            same = movie.read_bytes() == animated.read_bytes()
        finally:
            viewer.stop()
            server.terminate()
            server.wait(timeout=10)
    ours, theirs = statistics.median(viewer_times), statistics.median(animate_times)
    print(
        f"viewer GIF export of the starfish animation ({fps:g} fps, Xvfb, median of {repeats}, "
        "in turn with animate)"
    )
    turns = [", ".join(f"{t:.2f}" for t in times) for times in (viewer_times, animate_times)]
    print(f"  viewer Ctrl+E to 'exported':    {ours:6.2f} s (turns {turns[0]})")
    print(f"  animate, process start to exit: {theirs:6.2f} s (turns {turns[1]})")
    print(f"  ratio {ours / theirs:.2f}x; the two GIFs are {'the same bytes' if same else 'DIFFERENT'}\n")


class ViewerChild:
    """A viewer child process in test mode whose milestone lines are read on a thread.

    Parameters
    ----------
    command : list of str
    environment : dict
    """

    def __init__(self, command: list[str], environment: dict):
        self.process = subprocess.Popen(
            command, env=environment, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        self.lines: queue.Queue = queue.Queue()
        self.seen: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in self.process.stdout:
            self.lines.put(line.strip())
        self.lines.put(None)  # the viewer closed its output: it ended

    def wait_for(self, prefix: str, timeout: float = EXPORT_TIMEOUT) -> str:
        """The next milestone line that starts with `prefix`; `StepFailed` if the viewer ends or
        `timeout` seconds pass first."""
        deadline = time.monotonic() + timeout
        while True:
            try:
                line = self.lines.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                line = None
            if line is None:
                self.stop()
                errors = self.process.stderr.read().strip().splitlines()[-CHILD_ERROR_LINES:]
                details = "\n".join(f"    {line}" for line in [*self.seen[-3:], *errors])
                raise StepFailed(f"the viewer GIF export: no '{prefix}' from the viewer:\n{details}")
            self.seen.append(line)
            if line.startswith(prefix):
                return line

    def stop(self) -> None:
        """End the viewer (SIGTERM: it saves and quits), killing it if it does not within 30 s."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
