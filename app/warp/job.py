"""One warp job: what ``warp`` and ``animate`` read from their arguments (or a session), and one run
of it for one frame or many.

A `WarpJob` holds everything a run needs and nothing it computes: the source image, the source
cage as a curve, `app.warp.pipeline.WarpSettings` (kernel, parameters, mesh size), the targets of its
frames (one for ``warp``, the keyframes' interpolation for ``animate``), the framing (output size,
image-to-output `View`, what shows outside) and the output with the kind of writer its name asks
for (`app.warp.frame_writers.WRITERS`).  `warp_job` builds one from ``warp``'s arguments,
`app.warp.animation.animation_job` from ``animate``'s; `run_job` draws it: the GL context first, then
the mesh and the basis functions (`app.warp.pipeline.prepare`, once), then
`app.warp.pipeline.write_frames`: one render per target into the file or the writer.  Every check
that can fail on bad input runs while the job is built, before the slow part.
"""

from __future__ import annotations

import argparse
import contextlib
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.console import ProgressBar, note
from app.io.files import (
    IMAGE_SUFFIXES,
    InputError,
    cage_curve,
    check_writable,
    kernel_names,
    read_cage,
    read_photo,
    refuse_overwriting_inputs,
    reported_as_input,
    same_file,
)
from app.io.images import has_alpha, output_format
from app.io.session import Session, existing_image, read_session
from app.render.viewport import View
from app.warp.fill import FILLS, chosen_fill
from app.warp.frame_writers import interrupted_by_sigterm
from app.warp.framing import CANVASES, OUTSIDES, output_frame, output_region
from app.warp.pins import pin_request, pinned_inputs
from app.warp.pipeline import Deformation, FrameOutput, OutputFile, WarpSettings

DEFAULT_KERNEL = "poisson"  # core.mesh_basis.DEFAULT_KERNEL, the deformation default
#: A target larger than this many times the output's larger side is reported.
ABSURD_TARGET_EXTENT = 100.0


@dataclass(frozen=True)
class WarpInputs:
    """What a job reads from a session or from image and cage files, before the image itself.

    Attributes
    ----------
    image_path : Path
    cage, target : ndarray of shape (n, 2)
        Source and target control points, image pixels.
    kernel : str
    params : dict
        The kernel's parameters as the session saved them (empty from files).
    parameterization : str
        The boundary parameter of the point kernels (``"natural"`` from files).
    max_edge : float or None
    outside, canvas : str
        What the output shows outside the warp, and what it frames (`app.warp.framing`).
    fill : str
        What fills the source cage's region behind the warp with ``outside = original``
        (`app.warp.fill`).
    fold_free : bool
        Deform by the certified fold-free map (`core.fold_free_deform`) instead of G P'.
    cage_source, target_source : str
        How messages name the cage and the target (a file, or ``SESSION: cage``).
    background : tuple of float or None
        Straight RGBA in [0, 1] under the warp (``--background``, or the session's); None: transparent.
    pinned : core.PinDeformation or None
        The pins' solve that gave the target (``--pins`` or the session's pins; `app.warp.pins`).
    """

    image_path: Path
    cage: np.ndarray
    target: np.ndarray
    kernel: str
    params: dict
    parameterization: str
    max_edge: float | None
    outside: str
    canvas: str
    fill: str
    fold_free: bool
    cage_source: str
    target_source: str
    background: tuple[float, float, float, float] | None = None
    pinned: object = None


@dataclass
class WarpJob:
    """A warp to draw: image, cage, settings, frames, framing and output.

    Attributes
    ----------
    image : ndarray of shape (H, W, 4), uint8 or uint16, or None
        The source image, RGBA; None once `run_job` has given it to the renderer (which draws a
        still into it: a 100-megapixel input is not held twice).
    image_path : Path
    curve : core.ClosedBSpline
        The source cage.
    source : str
        How errors of its meshing and of its kernel name it.
    settings : app.warp.pipeline.WarpSettings
    targets : tuple of ndarray of shape (n, 2)
        The target control points of each frame, image pixels.
    size : tuple of int
        (width, height) of the output.
    view : app.render.viewport.View
        Image pixels to output pixels.
    outside : str
        ``"original"`` or ``"transparent"``.
    fill : str
        What fills the source cage's region behind the warp (`app.warp.fill`).
    output : Path
    file : app.warp.pipeline.OutputFile or None
        How the output is written: a single image's format options, and the input's ICC profile
        and EXIF (also in an animation's PNG frames); None for no metadata.
    kind : str
        The writer: a key of `app.warp.frame_writers.WRITERS`, or ``"image"`` for one file
        (``warp``'s); both written by `app.warp.pipeline.write_frames`.
    fps : float
        Frames per second of an animation (0 for one image).
    mesh : core.Mesh or None
        The source cage's mesh at the job's mesh size, if made while the image was read
        (`warp_job`); None: `run_job` makes it.
    """

    image: np.ndarray
    image_path: Path
    curve: object  # core.ClosedBSpline (core is imported when a job runs)
    source: str
    settings: WarpSettings
    targets: tuple[np.ndarray, ...]
    size: tuple[int, int]
    view: View
    outside: str
    fill: str
    output: Path
    file: OutputFile | None
    kind: str
    fps: float = 0.0
    mesh: object = None  # core.Mesh (core is imported when a job runs)


def session_inputs(session: Session, path: Path, kernel: str | None = None) -> WarpInputs:
    """The image, cage, target, kernel (`kernel` instead, if given: then without the session's
    parameters, which are its own kernel's), mesh size and output choices of `session`, read from
    the file `path`."""
    chosen = session.kernel
    return WarpInputs(
        image_path=existing_image(session, path),
        cage=session.cage,
        target=session.target,
        kernel=chosen.name if kernel is None else kernel,
        # The viewer's kernel parameters and mesh, so that the output is exactly what it showed.
        params=chosen.params if kernel in (None, chosen.name) else {},
        parameterization=chosen.parameterization,
        max_edge=session.max_edge,
        outside=session.output.outside,
        canvas=session.output.canvas,
        fill=session.output.fill,
        fold_free=session.fold_free,
        cage_source=f"{path}: cage",
        target_source=f"{path}: target",
        background=session.output.background_rgba,
    )


def file_inputs(image: Path, cage: Path, target: Path | None, kernel: str | None) -> WarpInputs:
    """An image and two cage files (or one: the target is the pins' then, solved later): the
    package's defaults for everything else."""
    source = read_cage(cage)
    inputs = WarpInputs(
        image_path=image,
        cage=source,
        target=source if target is None else read_cage(target),
        kernel=DEFAULT_KERNEL if kernel is None else kernel,
        params={},
        parameterization="natural",
        max_edge=None,
        outside=OUTSIDES[0],
        canvas=CANVASES[0],
        fill=FILLS[0],
        fold_free=False,
        cage_source=str(cage),
        target_source=str(target or cage),
    )
    if len(inputs.target) != len(inputs.cage):
        raise InputError(
            f"{inputs.target_source}: has {len(inputs.target)} control points but {inputs.cage_source} "
            f"has {len(inputs.cage)}"
        )
    return inputs


def warp_job(args: argparse.Namespace) -> tuple[WarpJob, WarpInputs]:
    """``warp``'s arguments as a job of one frame, and the inputs it was made of.

    Raises
    ------
    InputError
        Anything wrong with the arguments or the files, before any slow work.
    """
    _require_warp_arguments(args)
    check_writable(args.output, suffix=IMAGE_SUFFIXES)
    session = None
    if args.session is not None:
        given = [f"--{name}" for name in ("cage", "target", "pins") if getattr(args, name) is not None]
        if args.image is not None or given:
            raise InputError(
                f"give either --session or IMAGE with --cage and --target, not both "
                f"({' and '.join(['IMAGE'] * (args.image is not None) + given)} with --session)"
            )
        session = read_session(args.session)
        inputs = session_inputs(session, args.session, args.kernel)
    else:
        inputs = file_inputs(args.image, args.cage, args.target, args.kernel)
    if inputs.kernel not in kernel_names():
        raise InputError(f"unknown kernel {inputs.kernel!r}; choose one of {', '.join(kernel_names())}")
    _refuse_overwriting_input(args.output, inputs.image_path, args.overwrite_input)
    refuse_overwriting_inputs(
        args.output,
        {
            "source cage": args.cage,
            "target cage": args.target,
            "pins": args.pins,
            "session file": args.session,
        },
    )
    request = pin_request(args, session)
    max_edge = inputs.max_edge if args.max_edge is None else args.max_edge
    photo, curve, mesh = _photo_curve_and_mesh(inputs, args.samples_per_segment, max_edge)
    image = photo.pixels
    inputs = pinned_inputs(inputs, curve, request)
    canvas = args.canvas or inputs.canvas
    outside = args.outside or inputs.outside
    fill = chosen_fill(args.fill, inputs.fill, outside)
    fold_free = args.fold_free or inputs.fold_free
    if fold_free and inputs.kernel != DEFAULT_KERNEL:
        raise InputError(
            f"--fold-free: fold-free warps are harmonic: use the {DEFAULT_KERNEL} kernel, "
            f"not {inputs.kernel!r}"
        )
    background = inputs.background if args.background is None else args.background
    _require_opaque_output(args.output, outside, background)
    with reported_as_input("output size"):
        size, view = output_frame(
            output_region(width_height(image), inputs.target, canvas), args.scale, args.size
        )
    _warn_if_target_is_absurd(inputs.target, size, inputs.target_source)
    params = kernel_params(inputs, args.samples_per_segment, args.parameterization)
    job = WarpJob(
        image=image,
        image_path=inputs.image_path,
        curve=curve,
        source=inputs.cage_source,
        settings=WarpSettings(inputs.kernel, params, max_edge, fold_free=fold_free),
        targets=(inputs.target,),
        size=size,
        view=view,
        outside=outside,
        fill=fill,
        output=args.output,
        file=OutputFile(args.output, photo.metadata, args.quality, background),
        kind="image",
        mesh=mesh,
    )
    return job, inputs


def _photo_curve_and_mesh(inputs: WarpInputs, samples_per_segment: int | None, max_edge: float | None):
    """The photograph of `inputs`, its cage as a curve (`checked_curve`) and the cage's mesh: the
    picture decoded on a worker thread while the cage is meshed on this one (OpenCV decodes without
    the GIL: the mesher's start, numba's first load of it, ~0.5 s, runs beside the decoding).

    Returns (photo, curve, mesh); mesh None if the mesher refused the cage (`run_job` meshes it
    again and says why).  The picture's errors come first, then the cage's, as when they were
    checked one after the other.
    """
    import core

    with ThreadPoolExecutor(max_workers=1) as worker:
        reading = worker.submit(read_photo, inputs.image_path)
        try:
            curve = cage_of(inputs, samples_per_segment)
        except InputError:
            reading.result()  # the picture's error first
            raise
        try:
            mesh = core.triangulate(curve, max_edge=max_edge)
        except ValueError:
            mesh = None
        photo = reading.result()
    _require_overlap(curve, width_height(photo.pixels), inputs.cage_source)
    return photo, curve, mesh


def run_job(job: WarpJob, target_source: str | None = None, report: bool = False, proven=None) -> list[str]:
    """Draw every frame of `job` into its output.

    Parameters
    ----------
    job : WarpJob
    target_source : str, optional
        How the fold warning names the target (``warp``'s); None: the deformation is not examined
        (``animate``).
    report : bool
        With `target_source`: also measure ``--report``'s worst Jacobians and the certificate.
    proven : core.InjectivityCertificate, optional
        What is proven already of the plain map to the job's target (the pins' solve's certificate):
        ``--report`` says it instead of proving the map again.

    Returns
    -------
    list of str
        ``--report``'s lines (`app.warp.report.examined`), to print; empty without it.

    Raises
    ------
    InputError
        A cage the mesher or the kernel refuses, an image the renderer cannot hold, an output
        that cannot be written; nothing is written then.
    app.render.renderer.ContextUnavailableError
        No OpenGL.
    """
    from app.render.renderer import WarpRenderer, create_headless_context, require_render_memory
    from app.warp.fill import set_fill
    from app.warp.pipeline import write_frames
    from app.warp.report import examined

    run = _STILL if job.kind == "image" else _FRAMES  # the one place the kind of job is read
    # The GL context comes first: without one there is no point in the long precompute.
    require_render_memory(width_height(job.image), job.size, context=True)
    ctx = create_headless_context()
    lines: list[str] = []
    steps = None
    try:
        try:
            started = time.perf_counter()
            deformation = _prepare(job, run)
            if target_source is not None:
                lines = examined(job, deformation, target_source, report, proven)
            with WarpRenderer(ctx) as renderer, interrupted_by_sigterm():
                with reported_as_input(str(job.image_path)):
                    renderer.set_image(job.image)
                set_fill(renderer, job.image, job.curve.control_points, job.fill, job.outside)
                job.image = None  # the renderer holds it now
                renderer.set_mesh(deformation.mesh.vertices, deformation.mesh.triangles)
                steps = write_frames(renderer, deformation, job.targets, frame_output(job))
                with run.progress(job) as bar:
                    for drawn in steps:
                        bar(drawn / len(job.targets))
                        if drawn == len(job.targets):
                            break  # what is left needs no GL context
        finally:
            ctx.release()
        with interrupted_by_sigterm():
            for _ in steps:  # a whole still's encoding, the frames' writer's finish
                pass
    finally:
        if steps is not None:
            steps.close()  # stopped early: nothing is left at the output's path
    seconds = time.perf_counter() - started
    note(run.wrote(job, len(deformation.mesh.vertices), seconds))
    return lines


def frame_output(job: WarpJob) -> FrameOutput:
    """What `app.warp.pipeline.write_frames` writes for `job`: a still into the image's own array
    (`run_job` lets go of it)."""
    return FrameOutput(
        job.file, job.kind, job.size, job.view, job.outside, job.fps, consume=job.kind == "image"
    )


def _prepare(job: WarpJob, run: _Run) -> Deformation:
    """The mesh of the job's cage and its basis functions, with progress and notes."""
    import core
    from app.warp.pipeline import prepare
    from core import COMPILE_MESSAGE as COMPILING

    kernel = job.settings.kernel
    mesh = job.mesh
    if mesh is None:
        with reported_as_input(f"{job.source}: meshing"):
            mesh = core.triangulate(job.curve, max_edge=job.settings.max_edge)
    if run.still:
        note(f"mesh: {len(mesh.vertices)} vertices, {len(mesh.triangles)} triangles")
    with (
        ProgressBar(COMPILING, announce=True) as compiling,
        ProgressBar(f"basis functions ({kernel})") as bar,
        reported_as_input(f"{job.source}: kernel {kernel!r}"),
    ):
        deformation = prepare(job.curve, job.settings, mesh, progress=bar, compiling=compiling)
    if compiling.seconds is not None:
        note(f"compiled the solver in {compiling.seconds:.1f} s (first run only; numba caches it)")
    if run.still and job.settings.fold_free:  # a strong cornered drag's takes up to a minute
        with (
            ProgressBar("fold-free map (share of the path proven)") as bar,
            reported_as_input(f"{job.source}: fold-free"),  # a fold-free path may cross itself
        ):
            deformation.fold_free_map(job.targets[0], bar)
    return deformation


def _wrote_still(job: WarpJob, vertices: int, seconds: float) -> str:
    return f"wrote {job.output} ({job.size[0]}x{job.size[1]}) in {seconds:.1f} s"


def _wrote_frames(job: WarpJob, vertices: int, seconds: float) -> str:
    return (
        f"wrote {job.output}: {len(job.targets)} frames of {job.size[0]}x{job.size[1]} at {job.fps:g} fps "
        f"({vertices} vertices) in {seconds:.1f} s"
    )


@dataclass(frozen=True)
class _Run:
    """What differs between a job of one still and one of frames, chosen once by `run_job`.

    Attributes
    ----------
    still : bool
        One image: the mesh is noted and a fold-free path proven with a progress bar of its own.
    progress : callable
        (job): a context manager giving the progress bar of the frames drawn (a silent one for a still).
    wrote : callable
        (job, vertices, seconds): the closing note.
    """

    still: bool
    progress: Callable
    wrote: Callable


def _no_progress(job: WarpJob) -> contextlib.nullcontext:
    return contextlib.nullcontext(lambda fraction: None)


def _frames_progress(job: WarpJob) -> ProgressBar:
    return ProgressBar(f"frames ({len(job.targets)})")


_STILL = _Run(True, _no_progress, _wrote_still)
_FRAMES = _Run(False, _frames_progress, _wrote_frames)


def width_height(image: np.ndarray) -> tuple[int, int]:
    """(width, height) of an image (H, W, channels)."""
    return image.shape[1], image.shape[0]


def checked_curve(inputs: WarpInputs, image: np.ndarray, samples_per_segment: int | None):
    """The source cage as a curve, `InputError` unless it is one and covers a pixel of `image`."""
    curve = cage_of(inputs, samples_per_segment)
    _require_overlap(curve, width_height(image), inputs.cage_source)
    return curve


def cage_of(inputs: WarpInputs, samples_per_segment: int | None):
    """The source cage as a curve, `InputError` unless it is one (`checked_curve` without the image)."""
    from core import checked_samples_per_segment

    if samples_per_segment is not None:
        with reported_as_input("--samples-per-segment"):
            checked_samples_per_segment(samples_per_segment, len(inputs.cage))
    return cage_curve(inputs.cage, inputs.cage_source, samples_per_segment)


def kernel_params(inputs: WarpInputs, samples_per_segment: int | None, parameterization: str | None) -> dict:
    """The kernel's parameters: the session's, then the command line's samples and parameterization."""
    from core import PARAMETERIZED_KERNELS

    params = dict(inputs.params)
    if samples_per_segment is not None:
        params["samples_per_segment"] = samples_per_segment
    if parameterization is not None:
        if inputs.kernel not in PARAMETERIZED_KERNELS and parameterization != "natural":
            raise InputError(
                f"--parameterization {parameterization}: kernel {inputs.kernel!r} does not depend on the "
                "boundary's parameterization; choose a point kernel (--kernel) or leave it out"
            )
    else:
        parameterization = inputs.parameterization
    if inputs.kernel in PARAMETERIZED_KERNELS:  # a session's choice does not bind the geometric kernels
        params["parameterization"] = parameterization
    return params


def _require_warp_arguments(args: argparse.Namespace) -> None:
    """`InputError` naming everything `warp` lacks, with an example command line."""
    missing = []
    if args.session is None:
        inputs = [
            name
            for name, value in (
                ("IMAGE", args.image),
                ("--cage", args.cage),
                ("--target or --pins", args.target or args.pins),
            )
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


def _require_opaque_output(output: Path, outside: str, background) -> None:
    """`InputError` before any work if `output` is a format without alpha (JPEG) and the warp leaves
    pixels transparent: outside the deformed region, unless --outside original or --background."""
    if not has_alpha(output_format(output)) and outside == "transparent" and background is None:
        raise InputError(
            f"{output}: JPEG has no transparency and the warp is transparent outside the deformed cage; "
            "give --outside original or --background COLOR"
        )


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
        # Only the pixels of the outline's box can be covered: a mask of those alone (not one byte
        # per pixel of a 100-megapixel image), its corner (left, top).
        left, top = max(int(np.floor(low[0])) - 1, 0), max(int(np.floor(low[1])) - 1, 0)
        right, bottom = min(int(np.ceil(high[0])) + 1, width), min(int(np.ceil(high[1])) + 1, height)
        mask = np.zeros((bottom - top, right - left), dtype=np.uint8)
        # Pixel (i, j) has its centre at (i + 0.5, j + 0.5); fillPoly samples integer points.
        points = np.round((outline - 0.5) * 16).astype(np.int32) - 16 * np.array([left, top], np.int32)
        cv2.fillPoly(mask, [points], 1, shift=4)
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


def _warn_if_target_is_absurd(target: np.ndarray, size: tuple[int, int], source: str) -> None:
    """Note a target cage (n, 2) whose extent dwarfs the output `size` (width, height):
    almost all of the deformed image then falls outside the picture."""
    extent = float(np.ptp(target, axis=0).max())
    if extent > ABSURD_TARGET_EXTENT * max(size):
        note(
            f"warning: {source}: the target spans {extent:.3g} pixels, {extent / max(size):.3g} times the "
            f"{size[0]}x{size[1]} output; the output shows only a tiny part of the deformed image"
        )
