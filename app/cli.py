"""The command line: ``python -m app COMMAND`` or ``transfinite-warp COMMAND`` (.docs/architecture.md,
"Files and conventions").

Commands: ``warp`` (deform an image with a source and a target cage and write a
PNG), ``animate`` (a session's keyframes as MP4, GIF or PNG frames,
`app.animate`), ``fit`` (a cage around an image's subject), ``compare`` (the kernels on
height data, the paper's Fig. 1, `app.compare`), ``bench`` (the performance table,
`app.bench`), and the interactive viewer (`app.viewer`): ``view`` (also what no
command opens: options without a command are the viewer's) and ``demo`` (a bundled
demo, optionally replaying its script).

Every argument and help text is defined here, in `build_parser`; each command's
module is imported only when that command runs.  Exit codes and what is printed on
stderr are `app.console`'s: 0 success, 1 the environment cannot run the command (no
OpenGL, not enough memory), 2 bad input.  Bad input is one line naming the file and
what is wrong, without a traceback, and no output file is written or changed.
"""

from __future__ import annotations

import argparse
import errno
import os
import select
import sys
import textwrap
import time
import warnings
from pathlib import Path

import numpy as np

from app.console import (
    EXIT_BAD_INPUT,
    EXIT_BROKEN_PIPE,
    EXIT_ENVIRONMENT,
    EXIT_INTERRUPTED,
    EXIT_OK,
    ProgressBar,
    discard_notes,
    fail,
    note,
    note_warning,
    print_notes,
)
from app.files import (
    InputError,
    cage_curve,
    check_writable,
    kernel_names,
    read_cage,
    read_image,
    read_session,
    refuse_overwriting_inputs,
    reported_as_input,
    same_file,
    session_image,
    session_kernel_params,
    session_max_edge,
    session_output,
    session_parameterization,
    write_cage,
    write_png,
)
from app.framing import CANVASES, OUTSIDES, output_frame, output_region
from app.keyframes import MAX_FPS, MIN_FPS
from app.render import ContextUnavailableError
from app.viewer.demos import SCRIPT_FORMAT
from core.arc_length import PARAMETERIZATIONS
from core.compilation import GRADIENT_MESSAGE as GRADIENT_COMPILING
from core.compilation import MESSAGE as COMPILING
from core.kernel_table import COMPILED_KERNELS

DEFAULT_KERNEL = "poisson"  # core.mesh_basis.DEFAULT_KERNEL, the deformation default
# cv2.Error.StsNoMem, without importing cv2 for the commands that never use it.
_OPENCV_NO_MEMORY = -4


def _stdout_reader_gone() -> bool:
    """Whether standard output is a pipe whose reader has closed it (poll reports an error on
    it); False where that cannot be told (no poll, no file descriptor)."""
    try:
        poller = select.poll()
        poller.register(sys.stdout.fileno(), select.POLLOUT)
        return any(event & (select.POLLERR | select.POLLHUP) for _, event in poller.poll(0))
    except (AttributeError, OSError, ValueError):
        return False


def main(argv: list[str] | None = None) -> int:
    """Run one command; returns the exit code.

    Parameters
    ----------
    argv : list of str, optional
        Arguments without the program name; ``sys.argv[1:]`` by default.  Without a
        command (no arguments, or options only) they go to ``view``.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or (argv[0].startswith("-") and argv[0] not in ("-h", "--help")):
        argv = ["view", *argv]  # the viewer, on the bundled demo unless told otherwise
    parser = build_parser(program_name())
    with warnings.catch_warnings():
        warnings.showwarning = note_warning
        try:
            # argparse exits on --help and on usage errors (after printing one line, see _Parser).
            args = parser.parse_args(argv)
        except SystemExit as exit:
            return int(exit.code or 0)
        discard_notes()
        try:
            code = args.run(args)
        except InputError as error:
            return fail(f"error: {error}", EXIT_BAD_INPUT)
        except ContextUnavailableError as error:
            return fail(f"error: {error}", EXIT_ENVIRONMENT)
        except KeyboardInterrupt:
            return fail("interrupted", EXIT_INTERRUPTED)
        except BrokenPipeError:
            # `... | head` read what it wanted: stop quietly, and send what is still buffered
            # nowhere, or Python's own flush at exit fails again. Any other pipe (the viewer's
            # worker gone) is an error like any other.
            if not _stdout_reader_gone():
                raise
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            return EXIT_BROKEN_PIPE
        except OSError as error:
            # A path that the system refuses (too long, a loop of links, ...) where no check
            # caught it first: the input's fault, named with the file.
            if error.errno == errno.ENOMEM:
                return fail(f"error: out of memory: {error.strerror}", EXIT_ENVIRONMENT)
            if error.filename is None:
                raise
            return fail(f"error: {error.filename}: {error.strerror or error}", EXIT_BAD_INPUT)
        except Exception as error:
            # The machine, not the input: an allocation failed (numpy, OpenCV or our own decoding).
            if not _out_of_memory(error):
                raise
            return fail(f"error: out of memory: {_memory_detail(error)}", EXIT_ENVIRONMENT)
        print_notes()
        return code


def program_name(argv0: str | None = None) -> str:
    """The name the user started the program by: ``python -m app``, or the console script's name.

    Parameters
    ----------
    argv0 : str, optional
        ``sys.argv[0]`` by default: the path of ``app/__main__.py`` under ``python -m app``,
        the script's path (``.../bin/transfinite-warp``) when run as the console script.
    """
    name = Path(sys.argv[0] if argv0 is None else argv0).name
    return "python -m app" if name in ("__main__.py", "-m", "-c", "") else name


def build_parser(prog: str = "python -m app") -> argparse.ArgumentParser:
    """The argument parser of every command, with `prog` as the program name in usage lines."""
    parser = _Parser(
        prog=prog,
        description="Image deformation with transfinite barycentric coordinates on B-spline cages.",
        epilog=_examples(
            ("%(prog)s", "the viewer on the bundled starfish demo"),
            ("%(prog)s --stats", "the same: options without a command are the viewer's"),
            ("%(prog)s view photo.png", "the viewer on your image (a cage is fitted)"),
            ("%(prog)s demo pattern --play", "a demo, playing its keyframed animation"),
            ("%(prog)s warp photo.png --cage c.json --target t.json --output out.png", None),
            ("%(prog)s COMMAND --help", "every option of COMMAND"),
        )
        + "\n\nexit status: 0 success, 1 the environment cannot run the command (no OpenGL,\n"
        "a failed bench step), 2 bad input (one line on stderr says what and where)",
        formatter_class=_HelpFormatter,
    )
    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser, metavar="COMMAND")
    kernels = kernel_names()

    warp = _command(
        commands,
        "warp",
        "deform an image from a source cage to a target cage",
        "Deform IMAGE by moving CAGE's control points to TARGET's and write the result as\n"
        "an RGBA PNG, transparent outside the deformed cage (or, with --outside original,\n"
        "over the untouched picture).  Cage files are JSON\n"
        '{"control_points": [[x, y], ...]} in image pixels, x right, y down, origin at the\n'
        "image's top-left corner.  Images and cages to try it on come with the program:\n"
        "python -m app demo --list prints where they are.",
        ("%(prog)s photo.png --cage cage.json --target target.json --output out.png", None),
        ("%(prog)s photo.png --cage c.json --target t.json --output out.png --kernel mean-value", None),
        ("%(prog)s --session photo.json --output out.png", "what the viewer showed, saved in photo.json"),
        (
            "%(prog)s p.png --cage c.json --target t.json --output o.png --outside original --canvas grow",
            "keep the rest of the picture, and widen it where the target leaves the image",
        ),
    )
    warp.add_argument("image", nargs="?", type=Path, metavar="IMAGE", help="source image (or give --session)")
    warp.add_argument("--cage", type=Path, help="source cage JSON, image pixels")
    warp.add_argument("--target", type=Path, help="target cage JSON, same number of control points")
    warp.add_argument(
        "--session",
        type=Path,
        help="session JSON of the viewer: image, cage, target and kernel; its target, not its keyframes "
        "(animate plays those); the output is framed like the image, not like the viewer's window",
    )
    warp.add_argument("--output", type=Path, help="output PNG (RGBA); required")
    warp.add_argument(
        "--kernel",
        metavar="NAME",
        help=f"one of {', '.join(kernels)} (default: {DEFAULT_KERNEL}, or the session's)",
    )
    warp.add_argument(
        "--parameterization",
        choices=PARAMETERIZATIONS,
        help="the boundary parameter of the point kernels' integrals: natural (the B-spline's, the "
        "default, or the session's) or arc-length (the paper's Fig. 12; harmonic and pgw do not "
        "depend on it)",
    )
    warp.add_argument(
        "--max-edge", type=_positive(float), metavar="PX", help="longest mesh edge in image pixels"
    )
    size = warp.add_mutually_exclusive_group()
    size.add_argument("--scale", type=_positive(float), metavar="S", help="output size = input size x S")
    size.add_argument(
        "--size", type=_size, metavar="WxH", help="output size; the image is fitted and centred"
    )
    warp.add_argument(
        "--outside",
        choices=OUTSIDES,
        help="what the output shows outside the deformed region: transparent (the default, or the "
        "session's), or original: the untouched image, so pixels away from both cages are exactly the "
        "input; where the source cage's region is not covered by the deformed one, the original is seen",
    )
    warp.add_argument(
        "--fill",
        metavar="FILL",
        help="with --outside original, what fills the source cage's region (the subject's original "
        "position) under the warp: none (the default, or the session's), transparent, a colour such as "
        "#ffffff, or inpaint (the surroundings continued inwards)",
    )
    warp.add_argument(
        "--canvas",
        choices=CANVASES,
        help="source: the output frames the input image (the default, or the session's); grow: it "
        "widens to hold the whole target curve, so a target that leaves the image is not clipped",
    )
    warp.add_argument(
        "--samples-per-segment",
        type=_positive(int),
        metavar="K",
        help="boundary samples per B-spline span (default: the kernel's)",
    )
    warp.add_argument(
        "--overwrite-input",
        action="store_true",
        help="allow --output to be the input image (otherwise refused)",
    )
    warp.add_argument(
        "--report",
        action="store_true",
        help="print on stdout, one line each, the deformation's smallest det J (area change), largest "
        "conformal distortion sigma1/sigma2 (over det J > 0) and how many points fold (det J <= 0), with "
        "where the extremes are in source-image pixels.  Point kernels: the exact Jacobian "
        "sum_i P'_i grad G_i at the interior mesh vertices (core.basis_gradients); harmonic, pgw and "
        "--parameterization arc-length have no pointwise gradients: the per-triangle Jacobian of the "
        "piecewise linear map at triangle centroids (exact for the finite-element harmonic basis)",
    )
    warp.set_defaults(run=_warp)

    fit = _command(
        commands,
        "fit",
        "fit a cage around the main subject of an image",
        "Write a cage (a closed quadratic B-spline) around the main subject of IMAGE: its\n"
        "alpha channel when it has one, a silhouette on a plain background, else the\n"
        "subject of the photograph (GrabCut, seeded by saliency, its outline then refined\n"
        "from the colours on either side; --rect says where it is).\n"
        "Around a photograph's subject the cage keeps a margin of 1.5% of its size.  When\n"
        "the subject is uncertain (tiny, or hardly told from the background by colour)\n"
        "a warning says so.  With --rect the cage always lies inside the rectangle: it\n"
        "is the rectangle itself when nothing stands out in it.",
        ("%(prog)s photo.jpg --output cage.json", None),
        ("%(prog)s photo.jpg --output cage.json --rect 120,40,300,420", "only what is inside the rectangle"),
        ("%(prog)s logo.png --output cage.json --points 24", None),
    )
    fit.add_argument(
        "image",
        type=Path,
        metavar="IMAGE",
        help="a photograph, a shape on a plain background, or a PNG with alpha",
    )
    fit.add_argument("--output", type=Path, required=True, help="cage JSON to write")
    fit.add_argument(
        "--points", type=_positive(int), default=16, metavar="N", help="control points (default 16)"
    )
    fit.add_argument(
        "--rect",
        metavar="X,Y,W,H",
        help="where the subject is, in image pixels (x right, y down from the top-left corner); "
        "nothing outside is chosen (default: found in the whole image)",
    )
    fit.set_defaults(run=_fit)

    compare = _command(
        commands,
        "compare",
        "compare the kernels on height data (the paper's Fig. 1)",
        "Interpolate heights given at the control points with every kernel on one mesh of\n"
        "the cage, print each one's distance to the harmonic interpolant (RMS and maximum)\n"
        "and draw them side by side in height bands.",
        ("%(prog)s --cage cage.json --output compare.png", None),
        ("%(prog)s --cage cage.json --output compare.png --kernel harmonic-like --kernel mean-value", None),
        (
            "%(prog)s --cage cage.json --output compare.png --kernel harmonic-like --parameterization both",
            "the natural and the arc-length parameterisation side by side",
        ),
    )
    compare.add_argument("--cage", type=Path, required=True, help="domain cage JSON")
    compare.add_argument(
        "--data",
        type=Path,
        help='JSON {"values": [F_1, ..., F_n]}, one height per control point (default: two waves in [0, 1])',
    )
    compare.add_argument("--output", type=Path, required=True, help="figure PNG")
    compare.add_argument(
        "--kernel",
        action="append",
        metavar="NAME",
        help=f"compare only this kernel, repeatable: {', '.join(kernels)} (harmonic, the reference, "
        "is always shown)",
    )
    compare.add_argument(
        "--parameterization",
        choices=(*PARAMETERIZATIONS, "both"),
        default="natural",
        help="the boundary parameter of the point kernels: natural (default), arc-length, or both side by "
        "side (the paper's Fig. 12)",
    )
    compare.add_argument(
        "--max-edge",
        type=_positive(float),
        metavar="LENGTH",
        help="longest mesh edge in cage units (default: diameter / 60)",
    )
    compare.set_defaults(run=_compare)

    quality = _command(
        commands,
        "quality",
        "folds, spill-out and distortion of every kernel on a standard suite",
        "Deform a standard suite of cages (the demos and built-in non-convex shapes) by strong\n"
        "drags, multi-point moves and bends (a fixed seed) with every kernel, and print per kernel:\n"
        "the folded area, how many deformations fold, the vertices mapped outside the target\n"
        "curve, the conformal distortion s1/s2 (mean and 99th percentile, folds counted as 10),\n"
        "the distance to the finite-element harmonic map and height interpolant, and the time.\n"
        "Self-crossing targets (every map folds there) are counted apart.",
        ("%(prog)s", "the table for every kernel (under a minute)"),
        ("%(prog)s --output quality.png", "also a figure of the hardest deformations"),
        ("%(prog)s --kernel power:power=2.5,shift=mean", "add a kernel with parameters"),
        (
            "%(prog)s --kernel harmonic-like:parameterization=arc-length",
            "a kernel in the arc length (Fig. 12)",
        ),
        ("%(prog)s --search", "the weight family 1/r^k, k in [1, 6], each shift (Eq. 19-20): ~10 minutes"),
    )
    quality.add_argument("--output", type=Path, metavar="FIG.png", help="figure PNG")
    quality.add_argument(
        "--kernel",
        action="append",
        metavar="NAME[:param=value,...]",
        help=f"add this kernel, repeatable: {', '.join(kernels)}",
    )
    quality.add_argument(
        "--search", action="store_true", help="measure the weight family 1/r^k instead of the kernels"
    )
    quality.add_argument(
        "--domain",
        action="append",
        metavar="NAME",
        help="only this domain of the suite, repeatable (the names are in the table's first line)",
    )
    quality.add_argument(
        "--seed", type=_natural, default=14, help="seed of the deformations, an integer >= 0 (default 14)"
    )
    quality.set_defaults(run=_quality)

    bench = _command(
        commands,
        "bench",
        "the performance table on this machine",
        "Time the kernels, the plain numpy baseline and the finite-element harmonic solve\n"
        "in one process (medians of repeated runs), then a 1,000,000-point solve and a 4K\n"
        "warp, each in a child process of its own.",
        ("%(prog)s", "the full table (a few minutes)"),
        ("%(prog)s --quick", "every row once at tiny sizes: a smoke test of about 20 s"),
    )
    bench.add_argument(
        "--quick",
        action="store_true",
        help="every row once at tiny sizes: a smoke test of about 20 s (on 2 busy cores; most of it starts "
        "child processes, solves poisson's densities and drags in a viewer under Xvfb)",
    )
    bench.add_argument(
        "--repeats", type=_positive(int), default=3, metavar="N", help="runs per row; the median is shown"
    )
    bench.add_argument(
        "--large", action="store_true", help="also the 1,000,000-vertex FEM comparison (minutes)"
    )
    bench.add_argument("--skip-fem", action="store_true", help="no finite-element comparison")
    bench.add_argument("--skip-memory", action="store_true", help="no 1,000,000-point memory run")
    bench.add_argument("--skip-warp", action="store_true", help="no end-to-end 4K warp")
    bench.add_argument(
        "--skip-drag", action="store_true", help="no viewer drag frame at 6k and 400k vertices (Xvfb)"
    )
    bench.set_defaults(run=_bench)

    view = _command(
        commands,
        "view",
        "the interactive viewer (the default command)",
        "Open the viewer: drag the target cage's control points and the image follows.\n"
        "Without IMAGE and --session it opens the bundled starfish demo.  The session is\n"
        "saved after every change and restored when the same session is opened again.",
        ("%(prog)s", "the bundled demo"),
        ("%(prog)s photo.png", "a cage is fitted around the main shape"),
        ("%(prog)s photo.png --cage cage.json --stats", None),
        ("%(prog)s --session my-edit.json", "reopen (or start) a session file"),
    )
    add_view_arguments(view)
    view.set_defaults(run=_view)

    demo = _command(
        commands,
        "demo",
        "the viewer on a bundled demo, optionally playing its animation",
        "Open the viewer on a bundled demo: starfish, character or pattern.  --play plays\n"
        "the demo's keyframes (its session NAME.session.json in the assets; Space pauses);\n"
        "--script and --frames replay scripted drags through the mouse's input path.\n\n"
        + textwrap.fill(SCRIPT_FORMAT, 80),
        ("%(prog)s pattern --play", "play the demo's keyframed animation, looping"),
        ("%(prog)s starfish --frames frames/", "write every replayed frame as a PNG, then quit"),
        ("%(prog)s character --script my-moves.json", None),
        ("%(prog)s --list", "where the demos' images and cages are, to try warp or fit on"),
    )
    demo.add_argument("name", nargs="?", metavar="NAME", help="starfish (default), character or pattern")
    demo.add_argument(
        "--list",
        action="store_true",
        help="print where each demo's image, cage, script and session are (to use with warp, fit, animate "
        "or view), and quit",
    )
    demo.add_argument(
        "--play",
        action="store_true",
        help="play the demo's keyframed animation at once (its scripted drags as keyframes), looping",
    )
    demo.add_argument("--script", type=Path, help="replay this script file instead (format above)")
    demo.add_argument(
        "--frames",
        type=Path,
        metavar="DIR",
        help="write every replayed frame as DIR/frame_NNNNN.png, then quit",
    )
    demo.add_argument(
        "--fps",
        type=_frame_rate,
        default=30.0,
        help=f"frames per second of --frames, {MIN_FPS:g} to {MAX_FPS:g} (default 30)",
    )
    demo.add_argument(
        "--session",
        type=Path,
        help="session JSON: restored if it exists, and saved after every change (default: the demo's own "
        "session file, the same one the program without a command opens)",
    )
    _add_viewer_options(demo)
    demo.set_defaults(run=_demo)

    animate = _command(
        commands,
        "animate",
        "render a session's keyframes as MP4, GIF or PNG frames",
        'Render the keyframed animation of SESSION (its "keyframes", made in the viewer:\n'
        "I adds a keyframe, Space plays) offscreen, antialiased like warp.  Frame k is at\n"
        "time k / fps from the first keyframe to the last, both included.  The output's\n"
        "name chooses the format: .mp4 (MPEG-4 video), .gif, or a folder (a name ending\n"
        "in /) of RGBA frame_NNNNN.png.  Video and GIF have no alpha: transparent parts\n"
        "are white.  The output appears only when complete (Ctrl+C leaves nothing).",
        ("%(prog)s walk.json --output walk.mp4", None),
        ("%(prog)s walk.json --output walk.gif --fps 15 --size 320x240", "a small GIF"),
        ("%(prog)s walk.json --output frames/ --outside original", "PNG frames over the untouched image"),
    )
    animate.add_argument("session", type=Path, metavar="SESSION", help="session JSON with keyframes")
    animate.add_argument(
        "--output", required=True, metavar="OUT", help="OUT.mp4, OUT.gif, or OUT_DIR/ for PNG frames"
    )
    animate.add_argument(
        "--fps",
        type=_frame_rate,
        default=30.0,
        metavar="N",
        help=f"frames per second, {MIN_FPS:g} to {MAX_FPS:g} (default 30)",
    )
    animate.add_argument(
        "--size", type=_size, metavar="WxH", help="output size; the frame is fitted and centred"
    )
    animate.add_argument(
        "--outside", choices=OUTSIDES, help="as for warp (default: the session's, else transparent)"
    )
    animate.add_argument(
        "--canvas", choices=CANVASES, help="as for warp; grow holds the target of every frame"
    )
    animate.add_argument(
        "--max-edge", type=_positive(float), metavar="PX", help="longest mesh edge (default: the session's)"
    )
    animate.set_defaults(run=_animate)
    return parser


def add_view_arguments(parser: argparse.ArgumentParser) -> None:
    """The arguments of ``view``, which are also those of the program without a command."""
    parser.add_argument(
        "image",
        nargs="?",
        type=Path,
        metavar="IMAGE",
        help="source image (a cage is fitted around its shape unless --cage)",
    )
    parser.add_argument("--cage", type=Path, help="source cage JSON, image pixels")
    parser.add_argument(
        "--session",
        type=Path,
        help="session JSON: restored if it exists, and saved after every change (default: the image's "
        "own session file in $XDG_STATE_HOME/transfinite-warp/sessions, ~/.local/state if XDG_STATE_HOME "
        "is unset, restored whenever the image is opened again)",
    )
    _add_viewer_options(parser)


def _add_viewer_options(parser: argparse.ArgumentParser) -> None:
    """The options that ``view`` and ``demo`` share."""
    parser.add_argument(
        "--fresh",
        action="store_true",
        help="start over instead of restoring the image's last session (the old session file is kept "
        "beside the new one, renamed)",
    )
    parser.add_argument(
        "--stats",
        action="store_true",
        help="on exit, print frames=N median_frame_ms=X p95_frame_ms=Y median_drag_frame_ms=Z (Z: the frames "
        "drawn while a control point is dragged; 0 without any)",
    )
    parser.add_argument(
        "--max-edge",
        type=_positive(float),
        metavar="PX",
        help="longest mesh edge in image pixels (default: about 6,000 vertices in the cage)",
    )
    parser.add_argument(
        "--vertices",
        type=_positive(int),
        metavar="N",
        help="mesh every cage with about N vertices instead (50,000 or more: dragged through a "
        "~20,000-vertex preview)",
    )
    parser.add_argument(
        "--export",
        type=Path,
        metavar="PNG",
        help="where Ctrl+E writes (default: asks, proposing STEM-warped.png beside the image, or in "
        "the current folder for a bundled demo or a read-only folder)",
    )
    parser.add_argument(
        "--window-size",
        type=_size,
        metavar="WxH",
        help="open the window at this size, in screen pixels (default: the size it had when last closed, "
        "else 90%% of the screen; never larger than the screen)",
    )
    parser.add_argument(
        "--parameterization",
        choices=PARAMETERIZATIONS,
        help="start with this boundary parameter of the point kernels: natural or arc-length (default: "
        "the session's, else natural; the panel switches it)",
    )
    parser.add_argument(
        "--kernel",
        metavar="NAME",
        help=f"start with this kernel (default: the session's, else {DEFAULT_KERNEL}; K and the panel "
        "switch it); harmonic and pgw compute a mesh first",
    )


def _command(commands, name: str, summary: str, description: str, *examples) -> argparse.ArgumentParser:
    """A subcommand with a one-line `summary` (in the command list), a `description` and `examples`."""
    return commands.add_parser(
        name,
        help=summary,
        description=description,
        epilog=_examples(*examples),
        formatter_class=_HelpFormatter,
    )


def _examples(*examples: tuple[str, str | None]) -> str:
    """An epilog: one command line per example, its explanation (if any) on the next line."""
    lines = ["examples:"]
    for command, explanation in examples:
        lines.append(f"  {command}")
        if explanation:
            lines.append(f"      {explanation}")
    return "\n".join(lines)


# -- commands -------------------------------------------------------------------


def _warp(args: argparse.Namespace) -> int:
    import core
    from app.fill import FILLS, chosen_fill, session_fill, set_fill
    from app.render import WarpRenderer, create_headless_context, require_render_memory
    from app.warping import WarpSettings, prepare, render
    from core.kernel_table import PARAMETERIZED_KERNELS
    from core.validation import checked_samples_per_segment

    _require_warp_arguments(args)
    check_writable(args.output, suffix=".png")
    if args.session is not None:
        given = [f"--{name}" for name in ("cage", "target") if getattr(args, name) is not None]
        if args.image is not None or given:
            raise InputError(
                f"give either --session or IMAGE with --cage and --target, not both "
                f"({' and '.join(['IMAGE'] * (args.image is not None) + given)} with --session)"
            )
        session = read_session(args.session)
        image_path, cage, target = session_image(session, args.session), session.cage, session.target
        kernel = session.kernel if args.kernel is None else args.kernel
        # The viewer's kernel parameters and mesh, so that the output is exactly what it showed.
        session_params = session_kernel_params(session, args.session) if kernel == session.kernel else {}
        parameterization = session_parameterization(session, args.session)
        if args.max_edge is None:
            args.max_edge = session_max_edge(session, args.session)
        outside, canvas = session_output(session, args.session)
        fill = session_fill(session.extra, args.session)
        cage_source, target_source = f"{args.session}: cage", f"{args.session}: target"
    else:
        image_path = args.image
        cage, target = read_cage(args.cage), read_cage(args.target)
        kernel = DEFAULT_KERNEL if args.kernel is None else args.kernel
        parameterization = "natural"
        outside, canvas = OUTSIDES[0], CANVASES[0]
        fill = FILLS[0]
        session_params = {}
        cage_source, target_source = str(args.cage), str(args.target)
        if len(target) != len(cage):
            raise InputError(
                f"{target_source}: has {len(target)} control points but {cage_source} has {len(cage)}"
            )
    if kernel not in kernel_names():
        raise InputError(f"unknown kernel {kernel!r}; choose one of {', '.join(kernel_names())}")
    _refuse_overwriting_input(args.output, image_path, args.overwrite_input)
    refuse_overwriting_inputs(
        args.output, {"source cage": args.cage, "target cage": args.target, "session file": args.session}
    )
    image = read_image(image_path)
    height, width = image.shape[:2]
    if args.samples_per_segment is not None:
        with reported_as_input("--samples-per-segment"):
            checked_samples_per_segment(args.samples_per_segment, len(cage))
    curve = cage_curve(cage, cage_source, args.samples_per_segment)
    _require_overlap(curve, (width, height), cage_source)
    outside, canvas = args.outside or outside, args.canvas or canvas
    fill = chosen_fill(args.fill, fill, outside)
    region = output_region((width, height), target, canvas)
    with reported_as_input("output size"):
        size, view = output_frame(region, args.scale, args.size)
    _warn_if_target_is_absurd(target, size, target_source)
    params = dict(session_params)
    if args.samples_per_segment is not None:
        params["samples_per_segment"] = args.samples_per_segment
    if args.parameterization is not None:
        parameterization = args.parameterization
        if kernel not in PARAMETERIZED_KERNELS and parameterization != "natural":
            raise InputError(
                f"--parameterization {parameterization}: kernel {kernel!r} does not depend on the boundary's "
                "parameterization; choose a point kernel (--kernel) or leave it out"
            )
    if kernel in PARAMETERIZED_KERNELS:  # a session's choice does not bind the geometric kernels
        params["parameterization"] = parameterization

    # The GL context comes first: without one there is no point in the long precompute.
    require_render_memory((width, height), size, context=True)
    ctx = create_headless_context()
    try:
        started = time.perf_counter()
        settings = WarpSettings(kernel, params, args.max_edge)
        with reported_as_input(f"{cage_source}: meshing"):
            mesh = core.triangulate(curve, max_edge=args.max_edge)
        note(f"mesh: {len(mesh.vertices)} vertices, {len(mesh.triangles)} triangles")
        with (
            ProgressBar(COMPILING, announce=True) as compiling,
            ProgressBar(f"basis functions ({kernel})") as bar,
            reported_as_input(f"{cage_source}: kernel {kernel!r}"),
        ):
            deformation = prepare(curve, settings, mesh, progress=bar, compiling=compiling)
        if compiling.seconds is not None:
            note(f"compiled the solver in {compiling.seconds:.1f} s (first run only; numba caches it)")
        deformed = deformation.positions(target)
        if args.report:
            with reported_as_input(f"{cage_source}: kernel {kernel!r}: gradients"):
                report = _distortion_report(curve, mesh, kernel, target, deformed, params)
        folded = np.count_nonzero(core.folded_triangles(mesh, deformed))
        if folded:
            note(
                f"warning: the deformation folds over in {folded} of {len(mesh.triangles)} triangles "
                f"({_why_folded(target, target_source)})"
            )
        require_render_memory((width, height), size, context=False)
        with WarpRenderer(ctx) as renderer:
            with reported_as_input(str(image_path)):
                renderer.set_image(image)
            set_fill(renderer, image, cage, fill, outside)
            renderer.set_mesh(mesh.vertices, mesh.triangles)
            with reported_as_input("rendering"):
                pixels = render(renderer, deformation, target, size, view, outside)
        write_png(args.output, pixels)
        note(f"wrote {args.output} ({size[0]}x{size[1]}) in {time.perf_counter() - started:.1f} s")
    finally:
        ctx.release()
    if args.report:
        print("\n".join(report))
    return EXIT_OK


def _why_folded(target: np.ndarray, target_source: str) -> str:
    """What to say of a target that folds the deformation: that it crosses itself, if it does."""
    import core

    try:
        core.ClosedBSpline(target)
    except ValueError as error:
        return f"{target_source}: {error}"
    return f"{target_source} may need a gentler move"


def _distortion_report(curve, mesh, kernel, target, deformed, params) -> list[str]:
    """The lines of ``warp --report``: worst det J, worst sigma1/sigma2, folded count, with where."""
    import core
    from core.distortion import triangle_jacobians, vertex_jacobians, worst_distortion

    if kernel in core.MESH_ONLY_KERNELS or params.get("parameterization", "natural") != "natural":
        # No pointwise gradients (FEM, PGW; the arc-length parameterisation): the Jacobians of
        # the piecewise linear map, exact for the FEM basis.
        jacobians = triangle_jacobians(mesh.vertices, deformed, mesh.triangles)
        where = mesh.vertices[mesh.triangles].mean(axis=1)
        points = "triangles (per-triangle Jacobian, at centroids)"
    else:
        if kernel in COMPILED_KERNELS:
            with ProgressBar(GRADIENT_COMPILING, announce=True) as compiling:
                core.compile_solver(compiling, gradients=True)
        _, gradients = core.mesh_basis_functions(curve, mesh, kernel=kernel, gradients=True, **params)
        jacobians = vertex_jacobians(gradients[mesh.interior], target)
        where = mesh.vertices[mesh.interior]
        points = "interior vertices (exact Jacobian)"
    worst = worst_distortion(jacobians, where)

    def at(point) -> str:
        return (
            f"at ({point[0]:.1f}, {point[1]:.1f}) px" if np.isfinite(point).all() else "(no unfolded point)"
        )

    return [
        f"min det J: {worst.smallest_determinant:.6g} {at(worst.smallest_at)}",
        f"max sigma1/sigma2: {worst.largest_distortion:.6g} {at(worst.largest_at)}",
        f"det J <= 0: {worst.folded} of {worst.count} {points}",
    ]


def _fit(args: argparse.Namespace) -> int:
    from app.fit import FIT_PIXELS, MAX_POINTS, checked_rect, fit_cage

    rect = None
    if args.rect is not None:
        try:
            rect = [float(part) for part in args.rect.split(",")]
        except ValueError:
            rect = []
        if len(rect) != 4:
            raise InputError(f"--rect: expected X,Y,W,H such as 40,30,200,150, got {args.rect!r}")
    check_writable(args.output, suffix=".json")
    refuse_overwriting_inputs(args.output, {"input image": args.image})
    if args.points > MAX_POINTS:
        raise InputError(f"--points {args.points}: at most {MAX_POINTS:,} control points can be fitted")
    if args.points < 3:
        raise InputError(f"--points {args.points}: a closed cage needs at least 3 control points")
    image = read_image(args.image)
    with reported_as_input(f"--rect {args.rect}"):
        rect = checked_rect(rect, image.shape[1], image.shape[0])
    with reported_as_input(str(args.image)):
        control_points = fit_cage(image, args.points, rect=rect)
    height, width = image.shape[:2]
    if height * width > FIT_PIXELS:
        note(f"fitted on a copy of about {FIT_PIXELS / 1e6:.1f} megapixels of the {width}x{height} image")
    write_cage(args.output, control_points)
    note(f"wrote {args.output} ({len(control_points)} control points)")
    return EXIT_OK


def _compare(args: argparse.Namespace) -> int:
    from app.compare import run_compare

    return run_compare(args)


def _quality(args: argparse.Namespace) -> int:
    from app.quality import run_quality

    return run_quality(args)


def _bench(args: argparse.Namespace) -> int:
    from app.bench import run_bench

    return run_bench(args)


def _animate(args: argparse.Namespace) -> int:
    from app.animate import run_animate

    return run_animate(args)


def _view(args: argparse.Namespace) -> int:
    from app.viewer.demos import DEFAULT_DEMO, demo_files
    from app.viewer.session import open_document
    from app.viewer.window import Options, run

    _check_viewer_outputs(args)
    if args.cage is not None and args.image is None:
        raise InputError("--cage needs an IMAGE")
    document = open_document(args.image, args.cage, args.session, args.max_edge, fresh=args.fresh)
    _choose_start(document, args.kernel, args.parameterization)
    _tell(document.notices)
    script = None
    if args.image is None and (args.session is None or not args.session.exists()):
        script = demo_files(DEFAULT_DEMO).script
    options = Options(
        stats=args.stats,
        max_edge=args.max_edge,
        vertices=args.vertices,
        script=script,
        export=args.export,
        size=args.window_size,
    )
    return run(document, options)


def _demo(args: argparse.Namespace) -> int:
    from app.viewer.demos import DEFAULT_DEMO, demo_files, demo_keyframes, read_script
    from app.viewer.session import begin_with, open_document, start_snapshot
    from app.viewer.window import Options, run

    if args.list:
        _list_demos()
        return EXIT_OK
    _check_viewer_outputs(args)
    files = demo_files(args.name or DEFAULT_DEMO)
    document = open_document(
        session=args.session, max_edge=args.max_edge, demo_name=files.name, fresh=args.fresh
    )
    replay = args.frames is not None or args.script is not None
    playback = args.play and not replay
    if replay or playback:
        # A script (or the keyframes) moves the demo's own control points: start from the demo's
        # start, one undoable step after whatever the session held.
        start, _ = start_snapshot(document.snapshot, document.image, files.cage)
        if playback:
            start = start.replace(keyframes=demo_keyframes(files))
        what = "play its animation" if playback else "replay its script"
        begin_with(document, start, f"back to the demo's start to {what} (Ctrl+Z: your last state)")
    _choose_start(document, args.kernel, args.parameterization)
    _tell(document.notices)
    script = args.script or files.script
    read_script(script, document.snapshot.n)  # bad scripts fail here, before the window opens
    if args.frames is not None and args.frames.exists() and not args.frames.is_dir():
        raise InputError(f"--frames {args.frames}: exists and is not a directory")
    options = Options(
        stats=args.stats,
        max_edge=args.max_edge,
        vertices=args.vertices,
        script=script,
        play=replay,
        playback=playback,
        frames=args.frames,
        fps=args.fps,
        export=args.export,
        size=args.window_size,
    )
    return run(document, options)


def _list_demos() -> None:
    """Print each bundled demo and the paths of its files (drawn into the cache if not shipped)."""
    from app.viewer.demos import DEMOS, demo_files

    for demo in DEMOS.values():
        files = demo_files(demo.name)
        print(f"{demo.name}: {demo.title}, {demo.description}")
        for what in ("image", "cage", "script", "session"):
            print(f"  {what:8} {getattr(files, what)}")


def _choose_start(document, kernel: str | None, parameterization: str | None) -> None:
    """Start the viewer with the kernel and boundary parameterization of the command line, each one
    undoable step."""
    from app.viewer.session import begin_with

    if kernel is not None:
        begin_with(
            document, document.snapshot.replace(kernel=kernel), f"kernel: {kernel} (Ctrl+Z: the session's)"
        )
    if parameterization is not None:
        changed = document.snapshot.replace(parameterization=parameterization)
        begin_with(document, changed, f"parameterization: {parameterization} (Ctrl+Z: the session's)")


def _tell(notices: list[str]) -> None:
    """What opening a document did (restored, kept aside, ...): one line each on stderr."""
    for notice in notices:
        print(f"note: {notice}", file=sys.stderr)


def _require_warp_arguments(args: argparse.Namespace) -> None:
    """`InputError` naming everything `warp` lacks, with an example command line."""
    missing = []
    if args.session is None:
        inputs = [
            name
            for name, value in (("IMAGE", args.image), ("--cage", args.cage), ("--target", args.target))
            if value is None
        ]
        if inputs:
            missing.append(f"{', '.join(inputs)} (or --session)")
    if args.output is None:
        missing.append("--output")
    if missing:
        raise InputError(
            f"warp needs {' and '.join(missing)}, e.g. warp photo.png --cage cage.json --target target.json "
            "--output out.png (images and cages to try: python -m app demo --list)"
        )


def _check_viewer_outputs(args: argparse.Namespace) -> None:
    if args.max_edge is not None and args.vertices is not None:
        raise InputError("--max-edge and --vertices both set the mesh size: give one")
    if args.kernel is not None and args.kernel not in kernel_names():
        raise InputError(f"unknown kernel {args.kernel!r}; choose one of {', '.join(kernel_names())}")
    inputs = {"input image": getattr(args, "image", None), "source cage": getattr(args, "cage", None)}
    if args.session is not None:
        check_writable(args.session, suffix=".json")
        refuse_overwriting_inputs(args.session, inputs)
    if args.export is not None:
        check_writable(args.export, suffix=".png")
        refuse_overwriting_inputs(args.export, {**inputs, "session file": args.session})


# -- helpers ----------------------------------------------------------------------


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


def _refuse_overwriting_input(output: Path, image: Path, allowed: bool) -> None:
    """`InputError` if `output` is the input `image` (the same file), unless `allowed`."""
    if same_file(output, image) and not allowed:
        raise InputError(
            f"{output}: is the input image; give another --output, or --overwrite-input to replace it"
        )


#: A target larger than this many times the output's larger side is reported.
ABSURD_TARGET_EXTENT = 100.0


def _warn_if_target_is_absurd(target: np.ndarray, size: tuple[int, int], source: str) -> None:
    """Note a target cage (n, 2) whose extent dwarfs the output `size` (width, height):
    almost all of the deformed image then falls outside the picture."""
    extent = float(np.ptp(target, axis=0).max())
    if extent > ABSURD_TARGET_EXTENT * max(size):
        note(
            f"warning: {source}: the target spans {extent:.3g} pixels, {extent / max(size):.3g} times the "
            f"{size[0]}x{size[1]} output; the output shows only a tiny part of the deformed image"
        )


def _out_of_memory(error: Exception) -> bool:
    """Whether `error` is an allocation failure: MemoryError, or OpenCV's StsNoMem (-4)."""
    return isinstance(error, MemoryError) or (
        type(error).__module__ == "cv2" and getattr(error, "code", None) == _OPENCV_NO_MEMORY
    )


def _memory_detail(error: Exception) -> str:
    detail = getattr(error, "err", None) or str(error)
    return detail or "an allocation failed"


class _HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Descriptions and examples as written; argument help wrapped between words, never inside
    a hyphenated name such as modified-mean-value-squared."""

    def _split_lines(self, text: str, width: int) -> list[str]:
        return textwrap.wrap(" ".join(text.split()), width, break_on_hyphens=False)


class _Parser(argparse.ArgumentParser):
    """argparse with usage errors as one line and exit code 2, like every other bad input."""

    def error(self, message: str):
        fail(f"{self.prog}: error: {message} (see --help)", EXIT_BAD_INPUT)
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


def _natural(text: str) -> int:
    """argparse type: an integer >= 0."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be an integer >= 0, got {text!r}")
    return value


def _frame_rate(text: str) -> float:
    """argparse type: frames per second within `app.keyframes.MIN_FPS` .. `MAX_FPS`."""
    value = _positive(float)(text)
    if not MIN_FPS <= value <= MAX_FPS:
        raise argparse.ArgumentTypeError(
            f"must be within {MIN_FPS:g}..{MAX_FPS:g} frames per second, got {text!r}"
        )
    return value


def _size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(part) for part in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT such as 1920x1080, got {text!r}") from None
    if width < 1 or height < 1:
        raise argparse.ArgumentTypeError(f"width and height must be positive, got {text!r}")
    return width, height
