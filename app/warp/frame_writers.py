"""Where the frames of an animation go: a folder of PNG frames, an MP4 or a GIF, chosen by the
output's name (`output_kind`, `WRITERS`).

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
from pathlib import Path

import numpy as np

from app.io.files import InputError, check_name_length, check_writable, encode_png
from app.io.images import ImageMetadata
from app.io.images.writing import eight_bit
from core import temporary_path

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
    that hold it (PNG frames, an image file).
    """

    def __init__(
        self, path: Path, size: tuple[int, int], fps: float = 0.0, metadata: ImageMetadata | None = None
    ):
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

    The frames are not held: each is flattened to RGB and spooled to a temporary file beside the
    output as it comes (3 bytes a pixel on disk); `finish` picks the palette from a few of them and
    quantizes and writes them one at a time from there (Pillow keeps them at 1 byte a pixel).
    """

    def __init__(self, path: Path, size: tuple[int, int], fps: float, metadata: ImageMetadata | None = None):
        super().__init__(path, size, fps, metadata)
        self.spool = temporary_path(self.path, suffix=".frames")
        self._stream = open(self.spool, "wb")  # noqa: SIM115 (closed by finish or abort)

    def add(self, rgba: np.ndarray) -> None:
        self._stream.write(np.ascontiguousarray(flatten(rgba)).tobytes())
        self.count += 1

    def finish(self) -> None:
        from PIL import Image

        self._stream.close()
        width, height = self.size
        count = height * width * 3

        def frame(index: int) -> np.ndarray:  # read, not mapped: a mapping's pages stay resident
            return np.fromfile(self.spool, np.uint8, count, offset=index * count).reshape(height, width, 3)

        picks = np.linspace(0, self.count - 1, min(PALETTE_FRAMES, self.count)).round().astype(int)
        sample = Image.fromarray(np.concatenate([frame(i) for i in sorted(set(picks))], axis=0))
        palette = sample.quantize(256, method=Image.Quantize.MEDIANCUT)
        images = (
            Image.fromarray(frame(i)).quantize(palette=palette, dither=Image.Dither.NONE)
            for i in range(self.count)
        )
        delay = gif_delays(self.count, self.fps)
        temporary = temporary_path(self.path)
        try:
            with open(temporary, "wb") as stream:
                next(images).save(
                    stream, format="GIF", save_all=True, append_images=images, duration=delay, loop=0
                )
                stream.flush()
                os.fsync(stream.fileno())
            os.replace(temporary, self.path)
        except BaseException:
            with contextlib.suppress(OSError):
                os.remove(temporary)
            raise
        finally:
            with contextlib.suppress(OSError):
                os.remove(self.spool)

    def abort(self) -> None:
        self._stream.close()
        with contextlib.suppress(OSError):
            os.remove(self.spool)


def gif_delays(count: int, fps: float) -> list[int]:
    """Milliseconds each of `count` GIF frames is shown at `fps`: whole hundredths of a second
    (all GIF can hold) whose running sum is frame k's true time k / fps rounded, so that the
    rounding does not add up (30 fps: 30, 30, 40, 30, 30, 40 ms, ...; 220 frames last 7.33 s,
    not 220 x 30 ms = 6.6 s).  At least 20 ms each, as browsers show shorter delays as 100 ms."""
    ends = np.round(100 * np.arange(count + 1) / fps).astype(int)
    return [10 * max(2, int(step)) for step in np.diff(ends)]


#: The writer of each kind of `output_kind`.
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
