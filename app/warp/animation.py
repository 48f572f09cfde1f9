"""``python -m app animate``: a session's keyframes rendered offscreen into an MP4, a GIF or PNG frames.

Frame k is the warp at time t_first + k / fps (`app.warp.keyframes.frame_times`),
drawn exactly as ``warp`` draws one target: the same job (`app.warp.job`), the
same mesh and basis functions (computed once), `app.warp.framing` for the output's
size, the renderer's multisampling, and ``--outside original`` over the
untouched image.  Per frame the only numerical work is one product G @ P'(t).
The output's name chooses its writer (`app.warp.frame_writers`): ``OUT.mp4``,
``OUT.gif`` or ``OUT_DIR/`` for PNG frames, each appearing only when complete.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from app.io.files import InputError, read_photo, refuse_overwriting_inputs, reported_as_input
from app.io.session import read_session
from app.warp.frame_writers import check_frames, check_output, output_kind
from app.warp.framing import frame_region, output_frame
from app.warp.job import WarpJob, checked_curve, kernel_params, session_inputs, width_height
from app.warp.keyframes import frame_times, interpolate
from app.warp.pins import session_pins
from app.warp.pipeline import OutputFile, WarpSettings


def animation_job(args: argparse.Namespace) -> WarpJob:
    """``animate SESSION --output OUT [--fps N] [--size WxH] [--outside] [--canvas] [--max-edge PX]
    [--background COLOR]``
    as a job of one frame per time of `app.warp.keyframes.frame_times`.

    ``args.output`` is the text the user typed (a trailing slash asks for a folder of PNG frames).

    Raises
    ------
    InputError
        Anything wrong with the arguments, the session or its image, before any slow work.
    """
    path = Path(args.output).expanduser()
    kind = output_kind(path, args.output)
    check_output(path, kind)
    refuse_overwriting_inputs(path, {"session file": args.session})
    session = read_session(args.session)
    inputs = session_inputs(session, args.session)
    # The keyframes hold the targets the session's pins made; the pins themselves are checked like
    # `warp --session`'s, so that a session one command refuses the other refuses too.
    session_pins(session, args.session)
    refuse_overwriting_inputs(path, {"session's image": session.image})
    keyframes, interpolation = session.animation.keyframes, session.animation.interpolation
    if not keyframes:
        raise InputError(
            f'{args.session}: has no "keyframes"; add them in the viewer (I: a keyframe at the current time) '
            "or see the README for the format"
        )
    with reported_as_input(str(args.session)):
        times = frame_times(keyframes, args.fps)
    canvas = args.canvas or inputs.canvas
    photo = read_photo(inputs.image_path)
    image = photo.pixels
    curve = checked_curve(inputs, image, None)
    with reported_as_input("output size"):
        size, view = output_frame(
            frame_region(width_height(image), keyframes, interpolation, times, canvas), size=args.size
        )
    check_frames(kind, len(times), size, path)  # before the slow part (`write_frames` checks it too)
    max_edge = inputs.max_edge if args.max_edge is None else args.max_edge
    return WarpJob(
        image=image,
        image_path=inputs.image_path,
        curve=curve,
        source=str(args.session),
        settings=WarpSettings(
            inputs.kernel, kernel_params(inputs, None, None), max_edge, fold_free=inputs.fold_free
        ),
        targets=tuple(interpolate(keyframes, float(moment), interpolation) for moment in times),
        size=size,
        view=view,
        outside=args.outside or inputs.outside,
        fill=inputs.fill,
        output=path,
        file=OutputFile(
            path, photo.metadata, background=inputs.background if args.background is None else args.background
        ),
        kind=kind,
        fps=args.fps,
    )
