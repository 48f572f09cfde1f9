"""The command line: ``python -m app COMMAND`` or ``transfinite-warp COMMAND`` (.docs/architecture.md,
"Files and conventions").

Commands: ``warp`` (deform an image with a source and a target cage and write a
PNG), ``animate`` (a session's keyframes as MP4, GIF or PNG frames,
`app.warp.animation`), ``fit`` (a cage around an image's subject), ``compare`` (the kernels on
height data, the paper's Fig. 1, `app.studies.compare`), ``bench`` (the performance table,
`app.bench.table`), and the interactive viewer (`app.viewer`): ``view`` (also what no
command opens: options without a command are the viewer's) and ``demo`` (a bundled
demo, optionally replaying its script).

Every argument and help text is `app.commands.arguments`'s; the functions that run the commands are
here, and each command's module is imported only when that command runs.  Exit codes and what is printed on
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
import warnings
from pathlib import Path

from app.commands.arguments import command_parser
from app.console import (
    EXIT_BAD_INPUT,
    EXIT_BROKEN_PIPE,
    EXIT_ENVIRONMENT,
    EXIT_INTERRUPTED,
    EXIT_OK,
    discard_notes,
    fail,
    note,
    note_warning,
    print_notes,
)
from app.io.files import (
    CAGE_SUFFIXES,
    InputError,
    check_writable,
    kernel_names,
    read_image,
    refuse_overwriting_inputs,
    reported_as_input,
    write_cage,
)
from app.render.renderer import ContextUnavailableError

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
    """The argument parser of every command (`app.commands.arguments`), with `prog` as the program name in
    usage lines; ``args.run`` is the command's function of this module."""
    runs = {
        "warp": _warp,
        "fit": _fit,
        "compare": _compare,
        "quality": _quality,
        "bench": _bench,
        "view": _view,
        "demo": _demo,
        "animate": _animate,
    }
    return command_parser(prog, runs)


# -- commands -------------------------------------------------------------------


def _warp(args: argparse.Namespace) -> int:
    from app.warp.job import run_job, warp_job
    from app.warp.pins import pin_report

    job, inputs = warp_job(args)
    proven = inputs.pinned.certificate if inputs.pinned is not None else None
    report = run_job(job, inputs.target_source, args.report, proven)
    if args.report and inputs.pinned is not None:
        report[:0] = pin_report(inputs.pinned)
    if report:
        print("\n".join(report))
    return EXIT_OK


def _fit(args: argparse.Namespace) -> int:
    from app.fit.subject import FIT_PIXELS, MAX_POINTS, checked_rect, fit_cage

    rect = None
    if args.rect is not None:
        try:
            rect = [float(part) for part in args.rect.split(",")]
        except ValueError:
            rect = []
        if len(rect) != 4:
            raise InputError(f"--rect: expected X,Y,W,H such as 40,30,200,150, got {args.rect!r}")
    check_writable(args.output, suffix=CAGE_SUFFIXES)
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
    write_cage(args.output, control_points, image_size=(width, height))
    note(f"wrote {args.output} ({len(control_points)} control points)")
    return EXIT_OK


def _compare(args: argparse.Namespace) -> int:
    from app.studies.compare import run_compare

    return run_compare(args)


def _quality(args: argparse.Namespace) -> int:
    from app.studies.quality import run_quality

    return run_quality(args)


def _bench(args: argparse.Namespace) -> int:
    from app.bench.table import run_bench

    return run_bench(args)


def _animate(args: argparse.Namespace) -> int:
    from app.warp.animation import animation_job
    from app.warp.job import run_job

    run_job(animation_job(args))
    return EXIT_OK


def _view(args: argparse.Namespace) -> int:
    from app.viewer.demos import DEFAULT_DEMO, demo_files
    from app.viewer.documents import open_document
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
    from app.viewer.documents import begin_with, open_document, start_snapshot
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
    from app.viewer.documents import begin_with

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
        check_writable(args.export, suffix=(".png", ".gif", ".mp4"))  # a still, or the keyframed animation
        refuse_overwriting_inputs(args.export, {**inputs, "session file": args.session})


# -- helpers ----------------------------------------------------------------------


def _out_of_memory(error: Exception) -> bool:
    """Whether `error` is an allocation failure: MemoryError, or OpenCV's StsNoMem (-4)."""
    return isinstance(error, MemoryError) or (
        type(error).__module__ == "cv2" and getattr(error, "code", None) == _OPENCV_NO_MEMORY
    )


def _memory_detail(error: Exception) -> str:
    detail = getattr(error, "err", None) or str(error)
    return detail or "an allocation failed"
