"""The arguments of every command, their help and their examples: `command_parser`, one small
function per command (``_warp_command``, ...), and the argparse types that check values as they
are parsed.  Usage errors are one line and exit code 2, like every other bad input
(`app.console`); what each command does is `app.commands.cli`'s.
"""

from __future__ import annotations

import argparse
import textwrap
from pathlib import Path

from app.console import EXIT_BAD_INPUT, fail
from app.io.files import kernel_names
from app.io.images import DEFAULT_QUALITY
from app.io.images.colours import parse_colour
from app.viewer.demos import SCRIPT_FORMAT
from app.warp.framing import CANVASES, OUTSIDES
from app.warp.job import DEFAULT_KERNEL
from app.warp.keyframes import MAX_FPS, MIN_FPS
from core import PARAMETERIZATIONS


def command_parser(prog: str, runs: dict) -> argparse.ArgumentParser:
    """The argument parser of every command, with `prog` as the program name in usage lines.

    Parameters
    ----------
    prog : str
    runs : dict
        Command name -> the function that runs it on the parsed arguments (``args.run``).
    """
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
    _warp_command(commands, kernels)
    _fit_command(commands)
    _compare_command(commands, kernels)
    _quality_command(commands, kernels)
    _bench_command(commands)
    _view_command(commands)
    _demo_command(commands)
    _animate_command(commands)
    for name, command in commands.choices.items():
        command.set_defaults(run=runs[name])
    return parser


def _warp_command(commands, kernels: tuple[str, ...]) -> None:
    """The warp command and its arguments."""
    warp = _command(
        commands,
        "warp",
        "deform an image from a source cage to a target cage",
        "Deform IMAGE by moving CAGE's control points to TARGET's and write the result:\n"
        "PNG, TIFF, JPEG or WebP by the output's extension, at the input's bit depth where\n"
        "the format allows, with its ICC profile and EXIF; transparent outside the deformed\n"
        "cage (or, with --outside original, over the untouched picture).  Cage files are\n"
        '{"control_points": [[x, y], ...]} JSON in image pixels, x right, y down, origin\n'
        "at the top-left corner of the image as displayed (after its EXIF orientation).\n"
        "Images and cages to try it on come with the program:\n"
        "python -m app demo --list prints where they are.",
        ("%(prog)s photo.png --cage cage.json --target target.json --output out.png", None),
        ("%(prog)s photo.png --cage c.json --target t.json --output out.png --kernel mean-value", None),
        ("%(prog)s --session photo.json --output out.png", "what the viewer showed, saved in photo.json"),
        ("%(prog)s p.png --cage c.json --pins pins.json --max-distortion 2 --output o.png --report", None),
        (
            "%(prog)s p.png --cage c.json --target t.json --output o.png --outside original --canvas grow",
            "keep the rest of the picture, and widen it where the target leaves the image",
        ),
    )
    warp.add_argument("image", nargs="?", type=Path, metavar="IMAGE", help="source image (or give --session)")
    warp.add_argument(
        "--cage", type=Path, help="source cage, JSON or SVG (its first closed path), image pixels"
    )
    warp.add_argument("--target", type=Path, help="target cage, JSON or SVG, same number of control points")
    warp.add_argument(
        "--pins",
        type=Path,
        metavar="PINS.json",
        help='instead of --target: pins in the picture, {"pins": [[x, y], ...], "moved": [[x, y], ...]} '
        "in image pixels; the target is the cage that takes each pin where it was moved (one pin: a "
        "translation, two: a similarity, more: the least departure from one; core.pin_deform)",
    )
    warp.add_argument(
        "--max-distortion",
        type=float,
        metavar="K",
        help="with --pins: sigma1/sigma2 <= K (K >= 1; 1 is rigid up to scale) and no fold anywhere in the "
        "picture, proven; the pins land as close as that allows (--report says how close)",
    )
    warp.add_argument(
        "--session",
        type=Path,
        help="session JSON of the viewer: image, cage, target and kernel; its target, not its keyframes "
        "(animate plays those); the output is framed like the image, not like the viewer's window",
    )
    _output_file_arguments(warp)
    _deformation_arguments(warp, kernels)
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
    _switch(warp, "--overwrite-input", "allow --output to be the input image (otherwise refused)")
    _checking_arguments(warp)


def _checking_arguments(warp: argparse.ArgumentParser) -> None:
    """``warp``'s checks of the deformation: ``--fold-free`` and ``--report``."""
    _switch(
        warp,
        "--fold-free",
        "a warp that provably never folds and still meets the target curve: composite harmonic maps "
        "along the straight path of cages, each certified injective (core.fold_free_deform; poisson only; "
        'a session with "fold_free": true asks for it too)',
    )
    _switch(
        warp,
        "--report",
        "print on stdout, one line each, the deformation's smallest det J (area change), largest "
        "conformal distortion sigma1/sigma2 (over det J > 0) and how many points fold (det J <= 0), with "
        "where the extremes are in source-image pixels.  Point kernels: the exact Jacobian "
        "sum_i P'_i grad G_i at the interior mesh vertices (core.basis_gradients); harmonic, pgw and "
        "--parameterization arc-length have no pointwise gradients: the per-triangle Jacobian of the "
        "piecewise linear map at triangle centroids (exact for the finite-element harmonic basis); "
        "then the injectivity certificate of the map (core.certify_injective; poisson only)",
    )


def _deformation_arguments(warp: argparse.ArgumentParser, kernels: tuple[str, ...]) -> None:
    """``warp``'s kernel, boundary parameterization and mesh size."""
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


def _output_file_arguments(warp: argparse.ArgumentParser) -> None:
    """warp's output file and its format's options."""
    warp.add_argument(
        "--output",
        type=Path,
        help="output image, its format by its extension: .png (RGBA, 8 or 16 bits like the input), "
        ".tif/.tiff (RGBA, 16 bits kept), .jpg/.jpeg (no transparency: give --outside original or "
        "--background), .webp; the input's ICC profile and EXIF are carried over; required",
    )
    warp.add_argument(
        "--quality",
        type=_quality_value,
        default=DEFAULT_QUALITY,
        metavar="Q",
        help=f"JPEG and WebP quality, 1-100 (default {DEFAULT_QUALITY})",
    )
    warp.add_argument(
        "--background",
        type=_colour,
        metavar="COLOR",
        help="fill what the warp leaves transparent with COLOR: a name (white, black, grey...), #rrggbb "
        "or r,g,b (0-255); needed for a JPEG output unless --outside original covers everything "
        "(default: the session's background, else transparent)",
    )


def _fit_command(commands) -> None:
    """The fit command and its arguments."""
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
        ("%(prog)s photo.jpg --output cage.svg", "the cage as an SVG path, for Inkscape or Illustrator"),
    )
    fit.add_argument(
        "image",
        type=Path,
        metavar="IMAGE",
        help="a photograph, a shape on a plain background, or a PNG with alpha",
    )
    fit.add_argument(
        "--output",
        type=Path,
        required=True,
        help="cage to write: .json, or .svg (a path of quadratic Béziers)",
    )
    fit.add_argument(
        "--points", type=_positive(int), default=16, metavar="N", help="control points (default 16)"
    )
    fit.add_argument(
        "--rect",
        metavar="X,Y,W,H",
        help="where the subject is, in image pixels (x right, y down from the top-left corner); "
        "nothing outside is chosen (default: found in the whole image)",
    )


def _compare_command(commands, kernels: tuple[str, ...]) -> None:
    """The compare command and its arguments."""
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
    compare.add_argument("--cage", type=Path, required=True, help="domain cage, JSON or SVG")
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


def _quality_command(commands, kernels: tuple[str, ...]) -> None:
    """The quality command and its arguments."""
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
    _switch(quality, "--search", "measure the weight family 1/r^k instead of the kernels")
    quality.add_argument(
        "--domain",
        action="append",
        metavar="NAME",
        help="only this domain of the suite, repeatable (the names are in the table's first line)",
    )
    quality.add_argument(
        "--seed", type=_natural, default=14, help="seed of the deformations, an integer >= 0 (default 14)"
    )


def _bench_command(commands) -> None:
    """The bench command and its arguments."""
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
    _switch(
        bench,
        "--quick",
        "every row once at tiny sizes: a smoke test of about 20 s (on 2 busy cores; most of it starts "
        "child processes, solves poisson's densities and drags in a viewer under Xvfb)",
    )
    bench.add_argument(
        "--repeats", type=_positive(int), default=3, metavar="N", help="runs per row; the median is shown"
    )
    _switch(bench, "--large", "also the 1,000,000-vertex FEM comparison (minutes)")
    _switch(bench, "--skip-fem", "no finite-element comparison")
    _switch(bench, "--skip-memory", "no 1,000,000-point memory run")
    _switch(bench, "--skip-warp", "no end-to-end 4K warp")
    _switch(
        bench,
        "--skip-photos",
        "no 24 and 100 megapixel PNG and JPEG warps against reading and writing them, nor the "
        "1600x1200 animation to GIF against PNG frames (about 4 minutes)",
    )
    _switch(
        bench,
        "--skip-drag",
        "no viewer drag frame at 6k and 400k vertices, nor its fold-free drag frame (Xvfb)",
    )
    _switch(
        bench,
        "--skip-launch",
        "no launch rows: a warp's start-up; the viewer's to a warpable picture (the demo, a 24 megapixel "
        "photograph; Xvfb)",
    )
    _switch(
        bench,
        "--skip-export",
        "no viewer GIF export of the starfish animation against animate (Xvfb, xdotool)",
    )
    _switch(
        bench,
        "--skip-pins",
        "no pins rows (core.pin_deform within a distortion bound at 16, 40 and 100 control points)",
    )
    _switch(bench, "--skip-fold-free", "no fold-free warp against libigl at 10k and 50k vertices")
    _switch(bench, "--skip-mesher", "no mesher against Triangle at 10k, 100k and 300k vertices")


def _view_command(commands) -> None:
    """The view command and its arguments."""
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


def _demo_command(commands) -> None:
    """The demo command and its arguments."""
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
    _switch(
        demo,
        "--list",
        "print where each demo's image, cage, script and session are (to use with warp, fit, animate "
        "or view), and quit",
    )
    _switch(
        demo,
        "--play",
        "play the demo's keyframed animation at once (its scripted drags as keyframes), looping",
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


def _animate_command(commands) -> None:
    """The animate command and its arguments."""
    animate = _command(
        commands,
        "animate",
        "render a session's keyframes as MP4, GIF or PNG frames",
        'Render the keyframed animation of SESSION (its "keyframes", made in the viewer:\n'
        "I adds a keyframe, Space plays) offscreen, antialiased like warp.  Frame k is at\n"
        "time k / fps from the first keyframe to the last, both included.  The output's\n"
        "name chooses the format: .mp4 (MPEG-4 video), .gif, or a folder (a name ending\n"
        "in /) of RGBA frame_NNNNN.png.  Video and GIF have no alpha: transparent parts\n"
        "are white, or --background's colour.  The output appears only when complete\n"
        "(Ctrl+C leaves nothing).",
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
    animate.add_argument(
        "--background",
        type=_colour,
        metavar="COLOR",
        help="as for warp: fill what the warp leaves transparent with COLOR (default: the session's "
        "background, else transparent PNG frames and white video and GIF)",
    )


def add_view_arguments(parser: argparse.ArgumentParser) -> None:
    """The arguments of ``view``, which are also those of the program without a command."""
    parser.add_argument(
        "image",
        nargs="?",
        type=Path,
        metavar="IMAGE",
        help="source image (a cage is fitted around its shape unless --cage)",
    )
    parser.add_argument("--cage", type=Path, help="source cage, JSON or SVG, image pixels")
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
    _switch(
        parser,
        "--fresh",
        "start over instead of restoring the image's last session (the old session file is kept "
        "beside the new one, renamed)",
    )
    _switch(
        parser,
        "--stats",
        "on exit, print frames=N median_frame_ms=X p95_frame_ms=Y median_drag_frame_ms=Z (Z: the frames "
        "drawn while a control point is dragged; 0 without any) fold_free_drag_frames=N max_folded_drawn=K "
        "median_fold_free_drag_frame_ms=X proven_after_release_ms=Y (the drag frames drawn with fold-free "
        "on, the most turned-over triangles one drew, their median time, and the time from the last release "
        "to a proof on the status line, or none) median_plain_drag_frame_ms=Z (drag frames with it off) "
        "fold_free_drag_frames_on_target=K (fold-free drag frames whose boundary was on the target curve) "
        "max_boundary_lag_px=D (the farthest, in image pixels, a boundary vertex of theirs was drawn from "
        "that curve) max_fold_free_drag_frame_ms=X (the slowest of them)",
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
        metavar="OUT",
        help="where Ctrl+E writes: OUT.png, or OUT.gif or OUT.mp4 for the keyframed animation (default: "
        "asks, proposing STEM-warped.png beside the image, or in the current folder for a bundled demo "
        "or a read-only folder)",
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


def _switch(parser: argparse.ArgumentParser, name: str, help: str) -> None:
    """An option without a value that switches something on (``store_true``)."""
    parser.add_argument(name, action="store_true", help=help)


def _examples(*examples: tuple[str, str | None]) -> str:
    """An epilog: one command line per example, its explanation (if any) on the next line."""
    lines = ["examples:"]
    for command, explanation in examples:
        lines.append(f"  {command}")
        if explanation:
            lines.append(f"      {explanation}")
    return "\n".join(lines)


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
    """argparse type: frames per second within `app.warp.keyframes.MIN_FPS` .. `MAX_FPS`."""
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


def _quality_value(text: str) -> int:
    """argparse type: a JPEG/WebP quality, an integer 1-100."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer 1-100, got {text!r}") from None
    if not 1 <= value <= 100:
        raise argparse.ArgumentTypeError(f"must be an integer 1-100, got {text!r}")
    return value


def _colour(text: str) -> tuple[float, float, float, float]:
    """argparse type: a colour (`app.io.images.colours.parse_colour`)."""
    try:
        return parse_colour(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
