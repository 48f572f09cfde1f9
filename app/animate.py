"""``python -m app animate``: a session's keyframes rendered offscreen into an MP4, a GIF or PNG frames.

Frame k is the warp at time t_first + k / fps (`app.keyframes.frame_times`),
drawn exactly as ``warp`` draws one target: the same mesh and basis functions
(computed once), `app.framing` for the output's size, the renderer's
multisampling, and ``--outside original`` over the untouched image.  Per frame
the only numerical work is one product G @ P'(t).

Outputs (chosen by the name):

- ``OUT.mp4``: OpenCV's video writer with the MPEG-4 Part 2 codec (``mp4v``, the
  one every opencv-python wheel has; H.264 is not in them).  Video has no alpha:
  transparent pixels are flattened over `BACKGROUND`, and an odd width or height
  is padded by one pixel of that colour (the codec needs even sizes).
- ``OUT.gif``: Pillow (OpenCV cannot write GIF), one 256-colour palette for the
  whole animation so that still parts do not flicker, flattened like MP4.
- ``OUT_DIR/`` (a name ending in a slash, an existing folder, or a name without
  an extension): ``frame_00000.png``, ... RGBA with straight alpha, exactly
  ``warp``'s pixels.

Every output is written beside its final place under a temporary name and
renamed when complete, so Ctrl+C (or an error) leaves no half-written file at
the output path, and an existing output untouched.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import signal
import time
from pathlib import Path

import numpy as np

from app.files import InputError, check_name_length, check_writable, encode_png
from app.framing import output_frame, output_region
from app.images import ImageMetadata
from app.images.writing import eight_bit
from app.keyframes import Keyframe, interpolate
from core.atomic_write import temporary_path

#: Straight RGB that MP4 and GIF frames show where the warp is transparent.
BACKGROUND = (255, 255, 255)
#: Frames that the GIF palette is made from (evenly spread over the animation).
PALETTE_FRAMES = 8
FRAME_NAME = re.compile(r"frame_\d{5}\.png")


def output_kind(path: Path, text: str | None = None) -> str:
    """ "mp4", "gif" or "png" (a folder of frames) for output `path` as the user typed it (`text`).

    Raises
    ------
    InputError
        Another extension.
    """
    text = str(path) if text is None else text
    suffix = path.suffix.lower()
    check_name_length(path)
    if text.endswith(("/", os.sep)) or os.path.isdir(path) or suffix == "":
        return "png"
    if suffix in (".mp4", ".gif"):
        return suffix[1:]
    raise InputError(
        f"{path}: the output must end in .mp4 or .gif, or be a folder (end it with /) for PNG frames"
    )


def check_output(path: Path, kind: str) -> None:
    """`InputError` early if the output cannot be written (before any rendering)."""
    if kind != "png":
        check_writable(path)
        return
    try:
        _check_folder(path)
    except OSError as error:  # a path too long, a loop of symbolic links, ...
        raise InputError(f"{path}: cannot write ({error.strerror or error})") from None


def _check_folder(path: Path) -> None:
    """`check_output` of a folder of PNG frames: new, or holding only frames, in a writable folder."""
    if path.exists() and not path.is_dir():
        raise InputError(f"{path}: exists and is not a folder")
    if path.is_dir():
        foreign = [entry.name for entry in path.iterdir() if not FRAME_NAME.fullmatch(entry.name)]
        if foreign:
            raise InputError(
                f"{path}: holds other files than frame_NNNNN.png ({foreign[0]}, ...); "
                "give an empty or a new folder"
            )
    parent = path.parent
    if not parent.is_dir():
        raise InputError(f"{path}: cannot write, directory {parent} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{path}: cannot write, permission denied in {parent}")


def frame_region(
    image_size: tuple[int, int], keyframes: tuple[Keyframe, ...], interpolation: str, times, canvas: str
) -> tuple[float, float, float, float]:
    """(x0, y0, x1, y1), image pixels: `app.framing.output_region` of every frame's target, joined.

    One frame for the whole animation: with ``canvas="grow"`` it holds the
    target curve at every time in `times` (interpolation may overshoot keyframes).
    """
    regions = np.array(
        [
            output_region(image_size, interpolate(keyframes, float(t), interpolation), canvas)
            for t in (times if canvas == "grow" else times[:1])
        ]
    )
    return (*regions[:, :2].min(axis=0), *regions[:, 2:].max(axis=0))


def flatten(rgba: np.ndarray) -> np.ndarray:
    """RGB uint8 (H, W, 3) of straight-alpha RGBA (H, W, 4), uint8 or uint16 (rounded to 8 bits: video
    and GIF have no more), composited over `BACKGROUND`."""
    rgba = eight_bit(rgba)
    alpha = rgba[..., 3:4].astype(np.float32) / 255.0
    colour = rgba[..., :3].astype(np.float32)
    return np.round(colour * alpha + np.asarray(BACKGROUND, np.float32) * (1.0 - alpha)).astype(np.uint8)


class FrameWriter:
    """Writes frames (RGBA, (H, W, 4), uint8 or uint16, straight alpha) to a temporary place; `finish`
    renames it.

    Use as a context manager: leaving it by an exception calls `abort`, which
    removes what was written; `finish` must be called for the output to appear.
    `metadata` (the image's ICC profile and EXIF) goes into the frames of formats
    that hold it (PNG frames).
    """

    def __init__(self, path: Path, size: tuple[int, int], fps: float, metadata: ImageMetadata | None = None):
        self.path, self.size, self.fps = Path(path), (int(size[0]), int(size[1])), float(fps)
        self.metadata = metadata
        self.count = 0

    def add(self, rgba: np.ndarray) -> None:
        raise NotImplementedError

    def finish(self) -> None:
        raise NotImplementedError

    def abort(self) -> None:
        raise NotImplementedError

    def __enter__(self) -> FrameWriter:
        return self

    def __exit__(self, exc_type, *exc_info) -> None:
        if exc_type is not None:
            self.abort()


class PngFrames(FrameWriter):
    """``frame_NNNNN.png`` files in a folder, RGBA: a temporary folder renamed to `path` at the end.

    An existing folder of frames is replaced as a whole (it holds only frames, `check_output`).
    """

    def __init__(self, path: Path, size: tuple[int, int], fps: float, metadata: ImageMetadata | None = None):
        super().__init__(path, size, fps, metadata)
        self.temporary = temporary_path(self.path)
        self.temporary.mkdir()

    def add(self, rgba: np.ndarray) -> None:
        # The image's depth (16-bit frames of a 16-bit image) and metadata, as warp writes them.
        (self.temporary / f"frame_{self.count:05d}.png").write_bytes(encode_png(rgba, self.metadata))
        self.count += 1

    def finish(self) -> None:
        old = None
        if self.path.exists():
            old = temporary_path(self.path, ".old")
            os.replace(self.path, old)
        os.replace(self.temporary, self.path)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)

    def abort(self) -> None:
        shutil.rmtree(self.temporary, ignore_errors=True)


class Mp4Writer(FrameWriter):
    """MPEG-4 Part 2 video (``mp4v``) through OpenCV, flattened over `BACKGROUND`, padded to even sizes."""

    def __init__(self, path: Path, size: tuple[int, int], fps: float, metadata: ImageMetadata | None = None):
        import cv2

        super().__init__(path, size, fps, metadata)
        self.padded = (size[0] + size[0] % 2, size[1] + size[1] % 2)
        # The container comes from the name's extension, so the temporary ends in .mp4 too.
        self.temporary = temporary_path(self.path, ".mp4")
        self.video = cv2.VideoWriter(
            str(self.temporary), cv2.VideoWriter_fourcc(*"mp4v"), self.fps, self.padded
        )
        if not self.video.isOpened():
            self.abort()
            raise InputError(f"{path}: this OpenCV cannot write MP4 video (no mp4v encoder)")

    def add(self, rgba: np.ndarray) -> None:
        import cv2

        frame = np.empty((self.padded[1], self.padded[0], 3), np.uint8)
        frame[...] = BACKGROUND
        frame[: rgba.shape[0], : rgba.shape[1]] = flatten(rgba)
        self.video.write(cv2.cvtColor(frame, cv2.COLOR_RGB2BGR))
        self.count += 1

    def finish(self) -> None:
        self.video.release()
        os.replace(self.temporary, self.path)

    def abort(self) -> None:
        self.video.release()
        with contextlib.suppress(OSError):
            os.remove(self.temporary)


class GifWriter(FrameWriter):
    """An animated GIF through Pillow, looping, one palette for all frames, flattened over `BACKGROUND`.

    The frames are kept (RGB, 3 bytes a pixel) until `finish`, which picks the
    palette from a few of them and writes the file.
    """

    def __init__(self, path: Path, size: tuple[int, int], fps: float, metadata: ImageMetadata | None = None):
        super().__init__(path, size, fps, metadata)
        self.frames: list[np.ndarray] = []

    def add(self, rgba: np.ndarray) -> None:
        self.frames.append(flatten(rgba))
        self.count += 1

    def finish(self) -> None:
        from PIL import Image

        picks = (
            np.linspace(0, len(self.frames) - 1, min(PALETTE_FRAMES, len(self.frames))).round().astype(int)
        )
        sample = Image.fromarray(np.concatenate([self.frames[i] for i in sorted(set(picks))], axis=0))
        palette = sample.quantize(256, method=Image.Quantize.MEDIANCUT)
        images = [Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE) for f in self.frames]
        delay = gif_delays(len(images), self.fps)
        temporary = temporary_path(self.path)
        try:
            with open(temporary, "wb") as stream:
                images[0].save(
                    stream, format="GIF", save_all=True, append_images=images[1:], duration=delay, loop=0
                )
                stream.flush()
                os.fsync(stream.fileno())
            os.replace(temporary, self.path)
        except BaseException:
            with contextlib.suppress(OSError):
                os.remove(temporary)
            raise

    def abort(self) -> None:
        self.frames.clear()


def gif_delays(count: int, fps: float) -> list[int]:
    """Milliseconds each of `count` GIF frames is shown at `fps`: whole hundredths of a second
    (all GIF can hold) whose running sum is frame k's true time k / fps rounded, so that the
    rounding does not add up (30 fps: 30, 30, 40, 30, 30, 40 ms, ...; 220 frames last 7.33 s,
    not 220 x 30 ms = 6.6 s).  At least 20 ms each, as browsers show shorter delays as 100 ms."""
    ends = np.round(100 * np.arange(count + 1) / fps).astype(int)
    return [10 * max(2, int(step)) for step in np.diff(ends)]


WRITERS = {"mp4": Mp4Writer, "gif": GifWriter, "png": PngFrames}


@contextlib.contextmanager
def interrupted_by_sigterm():
    """SIGTERM raises KeyboardInterrupt meanwhile, like Ctrl+C: the writers then clean up."""

    def stop(*_):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, stop)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


#: Most bytes of frames a GIF export keeps in memory until it writes the file.
MAX_GIF_BYTES = 4 << 30


def run_animate(args) -> int:
    """``animate SESSION --output OUT [--fps N] [--size WxH] [--outside] [--canvas] [--max-edge PX]``.

    ``args.output`` is the text the user typed (a trailing slash asks for a folder of PNG frames).
    """
    import core
    from app.console import EXIT_OK, ProgressBar, note
    from app.files import (
        cage_curve,
        read_photo,
        read_session,
        refuse_overwriting_inputs,
        reported_as_input,
        session_image,
        session_kernel_params,
        session_keyframes,
        session_max_edge,
        session_output,
    )
    from app.keyframes import frame_times
    from app.render import WarpRenderer, create_headless_context, require_render_memory
    from app.warping import WarpSettings, prepare, render
    from core.compilation import MESSAGE as COMPILING

    path = Path(args.output).expanduser()
    kind = output_kind(path, args.output)
    check_output(path, kind)
    refuse_overwriting_inputs(path, {"session file": args.session})
    session = read_session(args.session)
    session_image(session, args.session)
    refuse_overwriting_inputs(path, {"session's image": session.image})
    keyframes, interpolation = session_keyframes(session, args.session)
    if not keyframes:
        raise InputError(
            f'{args.session}: has no "keyframes"; add them in the viewer (I: a keyframe at the current time) '
            "or see the README for the format"
        )
    with reported_as_input(str(args.session)):
        times = frame_times(keyframes, args.fps)
    outside, canvas = session_output(session, args.session)
    outside, canvas = args.outside or outside, args.canvas or canvas
    params = session_kernel_params(session, args.session)
    max_edge = args.max_edge if args.max_edge is not None else session_max_edge(session, args.session)
    photo = read_photo(session.image)
    image = photo.pixels
    height, width = image.shape[:2]
    curve = cage_curve(session.cage, f"{args.session}: cage")
    with reported_as_input("output size"):
        size, view = output_frame(
            frame_region((width, height), keyframes, interpolation, times, canvas), size=args.size
        )
    if kind == "gif" and len(times) * size[0] * size[1] * 3 > MAX_GIF_BYTES:
        raise InputError(
            f"{path}: {len(times)} frames of {size[0]}x{size[1]} are too many for a GIF; write an MP4 or PNG "
            "frames, or give a smaller --size or --fps"
        )

    # The GL context comes first: without one there is no point in the long precompute.
    require_render_memory((width, height), size, context=True)
    ctx = create_headless_context()
    try:
        started = time.perf_counter()
        with reported_as_input(f"{args.session}: meshing"):
            mesh = core.triangulate(curve, max_edge=max_edge)
        with (
            ProgressBar(COMPILING, announce=True) as compiling,
            ProgressBar(f"basis functions ({session.kernel})") as bar,
            reported_as_input(f"{args.session}: kernel {session.kernel!r}"),
        ):
            settings = WarpSettings(session.kernel, params, max_edge)
            deformation = prepare(curve, settings, mesh, progress=bar, compiling=compiling)
        require_render_memory((width, height), size, context=False)
        if compiling.seconds is not None:
            note(f"compiled the solver in {compiling.seconds:.1f} s (first run only; numba caches it)")
        with WarpRenderer(ctx) as renderer, interrupted_by_sigterm():
            with reported_as_input(str(session.image)):
                renderer.set_image(image)
            renderer.set_mesh(mesh.vertices, mesh.triangles)
            with (
                WRITERS[kind](path, size, args.fps, photo.metadata) as writer,
                ProgressBar(f"frames ({len(times)})") as bar,
            ):
                for index, moment in enumerate(times):
                    target = interpolate(keyframes, float(moment), interpolation)
                    writer.add(render(renderer, deformation, target, size, view, outside))
                    bar((index + 1) / len(times))
                try:
                    writer.finish()
                except OSError as error:
                    raise InputError(f"{path}: cannot write ({error.strerror or error})") from None
    finally:
        ctx.release()
    note(
        f"wrote {path}: {len(times)} frames of {size[0]}x{size[1]} at {args.fps:g} fps "
        f"({len(mesh.vertices)} vertices) in {time.perf_counter() - started:.1f} s"
    )
    return EXIT_OK
