"""The command line: ``python -m app <command>`` (see DESIGN.md, "Command line and files").

Commands: ``warp`` (deform an image with a source and a target cage and write a
PNG), ``fit`` (a cage around an image's silhouette), ``compare`` (the kernels on
height data, the paper's Fig. 1), ``bench`` (``app.bench``), and the interactive
viewer (`app.viewer`): ``view`` (also what no arguments at all open, on the
bundled demo) and ``demo`` (a bundled demo, optionally replaying its script).

Exit codes: 0 success, 1 the environment cannot run the command (no OpenGL),
2 bad input.  Bad input is reported as one line on stderr naming the file and what
is wrong, without a traceback, and no output file is written or changed.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from app.files import (
    InputError,
    cage_curve,
    check_writable,
    kernel_names,
    read_cage,
    read_image,
    read_session,
    reported_as_input,
    session_kernel_params,
    session_max_edge,
    write_cage,
    write_png,
)
from app.render import ContextUnavailableError
from core.compilation import MESSAGE as COMPILING

EXIT_OK = 0
EXIT_ENVIRONMENT = 1
EXIT_BAD_INPUT = 2


def main(argv: list[str] | None = None) -> int:
    """Run one command; returns the exit code.

    Parameters
    ----------
    argv : list of str, optional
        Arguments without the program name; ``sys.argv[1:]`` by default.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv:
        argv = ["view"]  # the viewer on the bundled demo
    if argv[0] == "bench":
        from app import bench

        return bench.main(argv[1:])
    parser = build_parser()
    with warnings.catch_warnings():
        warnings.showwarning = _show_warning
        try:
            # argparse exits on --help and on usage errors (after printing one line, see _Parser).
            args = parser.parse_args(argv)
        except SystemExit as exit:
            return int(exit.code or 0)
        _pending_notes.clear()
        try:
            code = args.run(args)
        except InputError as error:
            return _fail(f"error: {error}", EXIT_BAD_INPUT)
        except ContextUnavailableError as error:
            return _fail(f"error: {error}", EXIT_ENVIRONMENT)
        except KeyboardInterrupt:
            return _fail("interrupted", 130)
        for message in _pending_notes:
            print(message, file=sys.stderr)
        _pending_notes.clear()
        return code


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of every command but ``bench`` (which parses its own)."""
    parser = _Parser(
        prog="python -m app", description="Image deformation with transfinite barycentric coordinates."
    )
    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser, metavar="COMMAND")

    warp = commands.add_parser("warp", help="deform an image from a source cage to a target cage")
    warp.add_argument("image", nargs="?", type=Path, help="source image (or give --session)")
    warp.add_argument("--cage", type=Path, help="source cage JSON, image pixels")
    warp.add_argument("--target", type=Path, help="target cage JSON, same number of control points")
    warp.add_argument(
        "--session",
        type=Path,
        help="session JSON: image, cage, target and kernel (its view is the viewer's; the output is framed "
        "like the image)",
    )
    warp.add_argument("--output", type=Path, required=True, help="output PNG (RGBA)")
    warp.add_argument("--kernel", help="kernel name (default: harmonic-like, or the session's)")
    warp.add_argument(
        "--max-edge", type=_positive(float), metavar="PX", help="longest mesh edge in image pixels"
    )
    size = warp.add_mutually_exclusive_group()
    size.add_argument("--scale", type=_positive(float), metavar="S", help="output size = input size x S")
    size.add_argument(
        "--size", type=_size, metavar="WxH", help="output size; the image is fitted and centred"
    )
    warp.add_argument(
        "--samples-per-segment",
        type=_positive(int),
        metavar="K",
        help="boundary samples per B-spline span (default: the kernel's)",
    )
    warp.set_defaults(run=_warp)

    fit = commands.add_parser("fit", help="fit a cage to the main silhouette of an image")
    fit.add_argument("image", type=Path)
    fit.add_argument("--output", type=Path, required=True, help="cage JSON to write")
    fit.add_argument(
        "--points", type=_positive(int), default=16, metavar="N", help="control points (default 16)"
    )
    fit.set_defaults(run=_fit)

    compare = commands.add_parser("compare", help="compare the kernels on height data (paper's Fig. 1)")
    compare.add_argument("--cage", type=Path, required=True, help="domain cage JSON")
    compare.add_argument(
        "--data", type=Path, help='JSON {"values": [F_1, ..., F_n]} (default: a wave in [0, 1])'
    )
    compare.add_argument("--output", type=Path, required=True, help="figure PNG")
    compare.add_argument(
        "--kernel",
        action="append",
        metavar="NAME",
        help="compare only this kernel (repeatable; harmonic is always the reference)",
    )
    compare.add_argument(
        "--max-edge",
        type=_positive(float),
        metavar="LENGTH",
        help="longest mesh edge in cage units (default: diameter / 60)",
    )
    compare.set_defaults(run=_compare)

    # Listed for --help only: main() hands "bench" to app.bench before parsing.
    commands.add_parser("bench", help="the performance table on this machine", add_help=False)

    view = commands.add_parser(
        "view", help="the interactive viewer (no IMAGE and no --session: the bundled demo)"
    )
    view.add_argument("image", nargs="?", type=Path, help="source image (the cage is fitted unless --cage)")
    view.add_argument("--cage", type=Path, help="source cage JSON, image pixels")
    view.add_argument(
        "--session",
        type=Path,
        help="session JSON: restored if it exists, and saved after every change (default: a file in "
        "~/.local/state/transfinite-warp/sessions)",
    )
    _viewer_options(view)
    view.set_defaults(run=_view)

    demo = commands.add_parser("demo", help="the viewer on a bundled demo, optionally replaying its script")
    demo.add_argument("name", nargs="?", help="starfish (default), character or pattern")
    demo.add_argument("--play", action="store_true", help="replay the demo's scripted drags at once")
    demo.add_argument("--script", type=Path, help="replay this script instead (JSON list of timed moves)")
    demo.add_argument(
        "--frames",
        type=Path,
        metavar="DIR",
        help="write every replayed frame as DIR/frame_NNNNN.png, then quit",
    )
    demo.add_argument("--fps", type=_positive(float), default=30.0, help="frames per second of --frames")
    demo.add_argument("--session", type=Path, help="session JSON to save to (default: per demo)")
    _viewer_options(demo)
    demo.set_defaults(run=_demo)
    return parser


def _viewer_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--stats", action="store_true", help="on exit, print frames=N median_frame_ms=X p95_frame_ms=Y"
    )
    parser.add_argument(
        "--max-edge",
        type=_positive(float),
        metavar="PX",
        help="longest mesh edge in image pixels (default: about 6,000 vertices in the cage)",
    )
    parser.add_argument(
        "--export", type=Path, metavar="PNG", help="where Ctrl+E writes (default: beside the session)"
    )


# -- commands -------------------------------------------------------------------


def _warp(args: argparse.Namespace) -> int:
    import core
    from app.render import View, WarpRenderer, create_headless_context

    check_writable(args.output, suffix=".png")
    if args.session is not None:
        given = [f"--{name}" for name in ("cage", "target") if getattr(args, name) is not None]
        if args.image is not None or given:
            raise InputError(
                f"give either --session or IMAGE with --cage and --target, not both "
                f"({' and '.join(['IMAGE'] * (args.image is not None) + given)} with --session)"
            )
        session = read_session(args.session)
        image_path, cage, target = session.image, session.cage, session.target
        kernel = args.kernel or session.kernel
        # The viewer's kernel parameters and mesh, so that the output is exactly what it showed.
        session_params = session_kernel_params(session, args.session) if kernel == session.kernel else {}
        if args.max_edge is None:
            args.max_edge = session_max_edge(session, args.session)
        cage_source, target_source = f"{args.session}: cage", f"{args.session}: target"
    else:
        missing = [
            name
            for name, value in (("IMAGE", args.image), ("--cage", args.cage), ("--target", args.target))
            if value is None
        ]
        if missing:
            raise InputError(f"warp needs {', '.join(missing)} (or --session)")
        image_path = args.image
        cage, target = read_cage(args.cage), read_cage(args.target)
        kernel = args.kernel or "harmonic-like"
        session_params = {}
        cage_source, target_source = str(args.cage), str(args.target)
        if len(target) != len(cage):
            raise InputError(
                f"{target_source}: has {len(target)} control points but {cage_source} has {len(cage)}"
            )
    if kernel not in kernel_names():
        raise InputError(f"unknown kernel {kernel!r}; choose one of {', '.join(kernel_names())}")
    image = read_image(image_path)
    height, width = image.shape[:2]
    curve = cage_curve(cage, cage_source)
    _require_overlap(curve, (width, height), cage_source)
    if args.scale is not None:
        size = (max(1, round(width * args.scale)), max(1, round(height * args.scale)))
        view = View(args.scale)
    elif args.size is not None:
        size = args.size
        view = View.fit((0.0, 0.0, width, height), size)
    else:
        size, view = (width, height), View()
    params = dict(session_params)
    if args.samples_per_segment is not None:
        params["samples_per_segment"] = args.samples_per_segment

    # The GL context comes first: without one there is no point in the long precompute.
    ctx = create_headless_context()
    try:
        started = time.perf_counter()
        with reported_as_input(f"{cage_source}: meshing"):
            mesh = core.triangulate(curve, max_edge=args.max_edge)
        note(f"mesh: {len(mesh.vertices)} vertices, {len(mesh.triangles)} triangles")
        with (
            ProgressBar(COMPILING) as compiling,
            ProgressBar(f"basis functions ({kernel})") as bar,
            reported_as_input(f"{cage_source}: kernel {kernel!r}"),
        ):
            basis = core.mesh_basis_functions(
                curve, mesh, kernel=kernel, progress=bar, compiling=compiling, **params
            )
        if compiling.seconds is not None:
            note(f"compiled the solver in {compiling.seconds:.1f} s (first run only; numba caches it)")
        deformed = basis @ target
        folded = np.count_nonzero(core.folded_triangles(mesh, deformed))
        if folded:
            note(
                f"warning: the deformation folds over in {folded} of {len(mesh.triangles)} triangles "
                f"({target_source} may need a gentler move)"
            )
        with WarpRenderer(ctx) as renderer:
            with reported_as_input(str(image_path)):
                renderer.set_image(image)
            renderer.set_mesh(mesh.vertices, mesh.triangles)
            renderer.set_positions(deformed)
            with reported_as_input("rendering"):
                pixels = renderer.render(size, view)
        write_png(args.output, pixels)
        note(f"wrote {args.output} ({size[0]}x{size[1]}) in {time.perf_counter() - started:.1f} s")
    finally:
        ctx.release()
    return EXIT_OK


def _fit(args: argparse.Namespace) -> int:
    from app.fit import fit_cage

    check_writable(args.output, suffix=".json")
    image = read_image(args.image)
    with reported_as_input(str(args.image)):
        control_points = fit_cage(image, args.points)
    write_cage(args.output, control_points)
    note(f"wrote {args.output} ({len(control_points)} control points)")
    return EXIT_OK


def _compare(args: argparse.Namespace) -> int:
    from app.compare import run_compare

    return run_compare(args)


def _view(args: argparse.Namespace) -> int:
    from app.viewer.demos import DEFAULT_DEMO, demo_files
    from app.viewer.session import open_document
    from app.viewer.window import Options, run

    _check_viewer_outputs(args)
    if args.cage is not None and args.image is None:
        raise InputError("--cage needs an IMAGE")
    document = open_document(args.image, args.cage, args.session, args.max_edge)
    script = None
    if args.image is None and (args.session is None or not args.session.exists()):
        script = demo_files(DEFAULT_DEMO).script
    return run(document, Options(stats=args.stats, max_edge=args.max_edge, script=script, export=args.export))


def _demo(args: argparse.Namespace) -> int:
    from app.viewer.demos import DEFAULT_DEMO, demo_files, read_script
    from app.viewer.session import default_session_path, open_document
    from app.viewer.window import Options, run

    _check_viewer_outputs(args)
    files = demo_files(args.name or DEFAULT_DEMO)
    session = args.session
    if session is None:
        session = default_session_path(f"demo-{files.name}")
        if session.exists():
            session.unlink()  # a demo starts afresh; --session keeps one
    elif session.exists():
        raise InputError(f"{session} exists: a demo starts a new session (open that one with view --session)")
    document = open_document(files.image, files.cage, session, args.max_edge)
    script = args.script or files.script
    read_script(script, document.snapshot.n)  # bad scripts fail here, before the window opens
    if args.frames is not None and args.frames.exists() and not args.frames.is_dir():
        raise InputError(f"{args.frames}: not a directory")
    options = Options(
        stats=args.stats,
        max_edge=args.max_edge,
        script=script,
        play=args.play or args.frames is not None or args.script is not None,
        frames=args.frames,
        fps=args.fps,
        export=args.export,
    )
    return run(document, options)


def _check_viewer_outputs(args: argparse.Namespace) -> None:
    if args.session is not None:
        check_writable(args.session, suffix=".json")
    if args.export is not None:
        check_writable(args.export, suffix=".png")


# -- helpers ----------------------------------------------------------------------


class ProgressBar:
    """A text progress bar on stderr, fed with the fraction done in [0, 1].

    It redraws in place on a terminal and stays silent otherwise (logs and pipes
    get the one-line summary of the command instead of carriage returns).  At
    100 % it ends its line, so that the next bar starts on a fresh one.  Time
    counts from its first call; `seconds` is the time from there to 100 %.
    """

    WIDTH = 30

    def __init__(self, label: str, stream=None):
        self.label = label
        self.stream = stream or sys.stderr
        self.enabled = self.stream.isatty()
        self._shown = -1
        self._line = ""
        self._first_call: float | None = None
        self.seconds: float | None = None

    def __call__(self, fraction: float) -> None:
        now = time.perf_counter()
        if self._first_call is None:
            self._first_call = now
        percent = int(100 * min(max(fraction, 0.0), 1.0))
        if percent == 100:
            self.seconds = now - self._first_call
        if not self.enabled or percent == self._shown:
            return
        self._shown = percent
        filled = self.WIDTH * percent // 100
        elapsed = now - self._first_call
        self._line = (
            f"{self.label} [{'#' * filled}{'.' * (self.WIDTH - filled)}] {percent:3d}% {elapsed:5.1f} s"
        )
        self.stream.write(f"\r{self._line}")
        if percent == 100:
            self.stream.write("\n")
            self._line = ""
        self.stream.flush()

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, exc_type, *exc_info) -> None:
        if self._line:
            # On failure the bar is wiped, so that the error is the only line left.
            self.stream.write("\n" if exc_type is None else f"\r{' ' * len(self._line)}\r")
            self.stream.flush()


def _require_overlap(curve, image_size: tuple[int, int], source: str) -> None:
    """`InputError` if the domain does not cover a single pixel centre of the image."""
    import cv2

    width, height = image_size
    outline = curve(np.linspace(0.0, curve.n, 32 * curve.n, endpoint=False))
    low, high = outline.min(axis=0), outline.max(axis=0)
    if np.abs(outline).max() > 1e7:  # beyond what fillPoly's fixed point (and any image) holds
        raise InputError(f"{source}: control points lie over 10^7 pixels away; are they in image pixels?")
    if high[0] <= 0 or high[1] <= 0 or low[0] >= width or low[1] >= height:
        covered = 0
    else:
        mask = np.zeros((height, width), dtype=np.uint8)
        # Pixel (i, j) has its centre at (i + 0.5, j + 0.5); fillPoly samples integer points.
        cv2.fillPoly(mask, [np.round((outline - 0.5) * 16).astype(np.int32)], 1, shift=4)
        covered = int(np.count_nonzero(mask))
    if covered == 0:
        raise InputError(
            f"{source}: the cage lies entirely outside the {width}x{height} image "
            f"(its bounding box is x {low[0]:.4g}..{high[0]:.4g}, y {low[1]:.4g}..{high[1]:.4g})"
        )


# Notes and warnings of the running command, printed on stderr once it succeeds:
# when it fails, its error stays the only line.
_pending_notes: list[str] = []


def note(message: str) -> None:
    """Report `message` (one line) on stderr when the command has succeeded."""
    _pending_notes.append(" ".join(str(message).split()))


def _fail(message: str, code: int) -> int:
    _pending_notes.clear()
    print(" ".join(str(message).split()), file=sys.stderr, flush=True)
    return code


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    note(f"warning: {message}")


class _Parser(argparse.ArgumentParser):
    """argparse with usage errors as one line and exit code 2, like every other bad input."""

    def error(self, message: str):
        _fail(f"{self.prog}: error: {message} (see --help)", EXIT_BAD_INPUT)
        raise SystemExit(EXIT_BAD_INPUT)


def _positive(kind):
    """argparse type: a finite `kind` (int or float) > 0."""

    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected {'an integer' if kind is int else 'a number'}, got {text!r}"
            ) from None
        if not 0 < value < float("inf"):  # also rejects NaN
            raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text!r}")
        return value

    return parse


def _size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(part) for part in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT such as 1920x1080, got {text!r}") from None
    if width < 1 or height < 1:
        raise argparse.ArgumentTypeError(f"width and height must be positive, got {text!r}")
    return width, height
