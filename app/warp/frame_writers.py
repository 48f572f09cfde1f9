"""Where the frames of an animation go: a folder of PNG frames, an MP4 or a GIF, chosen by the
output's name (`output_kind`, `WRITERS`).

- ``OUT.mp4``: OpenCV's video writer with the MPEG-4 Part 2 codec (``mp4v``, the
  one every opencv-python wheel has; H.264 is not in them).  Video has no alpha:
  transparent pixels are flattened over `BACKGROUND`, and an odd width or height
  is padded by one pixel of that colour (the codec needs even sizes).
- ``OUT.gif``: written frame by frame as the frames come (nothing held but the last), one
  256-colour palette for the whole animation so that still parts do not flicker, each frame
  mapped to it by Pillow (OpenCV cannot write GIF) and only its box that changed encoded;
  flattened like MP4.
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
#: Frames that the GIF palette is made from (evenly spread over the animation: `lookahead`).
PALETTE_FRAMES = 8
#: Most pixels of those frames the palette is computed from (every k-th pixel of each): median cut
#: over 8 frames of 1600x1200 took 3.9 s, over a 1-megapixel sample 0.08 s, and mapped a frame with
#: the same error (36.7 dB against 36.6 dB).
PALETTE_PIXELS = 1 << 20
#: The GIF palette's index of the pixels a frame leaves as the previous one showed them (transparent);
#: the palette holds the 255 others.
UNCHANGED = 255
#: Most bytes of frames (RGB) a GIF is written with: beyond, an MP4 or PNG frames are the output to
#: write (`check_frames`).
MAX_GIF_BYTES = 4 << 30
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
    and GIF have no more), composited over `BACKGROUND` and rounded to the nearest level.

    Only the pixels neither opaque nor clear are blended: an opaque frame (``--outside original`` over
    an opaque picture) is a copy of its colour channels, a clear pixel the background."""
    import cv2

    rgba = eight_bit(rgba)
    rgb = cv2.cvtColor(rgba, cv2.COLOR_RGBA2RGB)
    alpha, pixels = rgba[..., 3].reshape(-1), rgb.reshape(-1, 3)
    pixels[alpha == 0] = BACKGROUND
    partial = np.flatnonzero((alpha != 0) & (alpha != 255))
    if len(partial):
        weight = alpha[partial].astype(np.uint32)[:, None]
        colour = rgba.reshape(-1, 4)[partial, :3].astype(np.uint32)
        pixels[partial] = (colour * weight + np.asarray(BACKGROUND, np.uint32) * (255 - weight) + 127) // 255
    return rgb


def check_frames(kind: str, count: int, size: tuple[int, int], path: Path) -> None:
    """`InputError` if `count` frames of `size` (width, height) are more than an output of `kind`
    (`output_kind`) is written with: a GIF of over `MAX_GIF_BYTES` of frames."""
    if kind == "gif" and count * size[0] * size[1] * 3 > MAX_GIF_BYTES:
        raise InputError(
            f"{path}: {count} frames of {size[0]}x{size[1]} are too many for a GIF; write an MP4 or PNG "
            "frames, or give a smaller --size or --fps"
        )


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

    def lookahead(self, count: int) -> list[int]:
        """Which of the `count` frames the writer wants to see (`preview`) before the first is added:
        none, but a GIF's palette frames."""
        return []

    def preview(self, rgba: np.ndarray) -> None:
        """One of the frames of `lookahead`, RGBA (H, W, 4), in their order, before the first is added."""

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
    """An animated GIF, looping, one palette for all frames, flattened over `BACKGROUND`, written to a
    temporary file beside the output as the frames come: nothing is held but the last frame's indices
    (H x W bytes) and its encoding until the next shows whether it lasts longer.

    The palette is the median cut of a sample of `PALETTE_PIXELS` pixels of the `lookahead` frames
    (or of the first frame, if none were previewed), 255 colours; each frame is mapped to it without
    dithering (Pillow), so that still parts keep their indices, and only the box that differs from
    the previous frame is encoded (LZW, Pillow's `GifImagePlugin.getdata`), its unchanged pixels
    transparent (`UNCHANGED`); a frame equal to the previous one lengthens its delay.
    """

    def __init__(self, path: Path, size: tuple[int, int], fps: float, metadata: ImageMetadata | None = None):
        super().__init__(path, size, fps, metadata)
        self.temporary = temporary_path(self.path)
        self._stream = open(self.temporary, "wb")  # noqa: SIM115 (closed by finish or abort)
        self._palette = None  # a Pillow "P" image holding the palette
        self._samples: list[np.ndarray] = []  # (N, 3) uint8: pixels of the previewed frames
        self._stride = 1
        self._previous: np.ndarray | None = None  # (H, W) uint8 indices of the last frame
        # (image, offset, milliseconds, GIF options) of the last frame, not yet written.
        self._pending: tuple | None = None

    def lookahead(self, count: int) -> list[int]:
        picks = np.linspace(0, count - 1, min(PALETTE_FRAMES, count)).round().astype(int)
        picks = sorted(set(picks.tolist()))
        self._sample_from(len(picks))
        return picks

    def _sample_from(self, frames: int) -> None:
        """Sample every `_stride`-th pixel of each of `frames` previews: `PALETTE_PIXELS` at most in
        all (an odd stride, so that the sample does not follow the columns)."""
        self._stride = -(-frames * self.size[0] * self.size[1] // PALETTE_PIXELS) | 1

    def preview(self, rgba: np.ndarray) -> None:
        self._samples.append(np.ascontiguousarray(flatten(rgba).reshape(-1, 3)[:: self._stride]))

    def _make_palette(self) -> None:
        """The median cut of the previewed pixels (`PALETTE_PIXELS` at most)."""
        from PIL import Image

        sample = np.concatenate(self._samples).reshape(-1, 1, 3)
        self._samples = []
        self._palette = Image.fromarray(sample).quantize(UNCHANGED, method=Image.Quantize.MEDIANCUT)

    def add(self, rgba: np.ndarray) -> None:
        from PIL import GifImagePlugin, Image

        if self._palette is None:
            if not self._samples:  # nothing previewed: the first frame's colours
                self._sample_from(1)
                self.preview(rgba)
            self._make_palette()
        indexed = Image.fromarray(flatten(rgba)).quantize(palette=self._palette, dither=Image.Dither.NONE)
        indices = np.asarray(indexed)
        delay = gif_delay(self.count, self.fps)
        self.count += 1
        if self._previous is None:
            self._stream.write(b"".join(GifImagePlugin.getheader(indexed, info={"loop": 0})[0]))
            self._previous = indices
            self._pending = (indexed, (0, 0), delay, {})
            return
        changed = indices != self._previous
        rows, columns = np.flatnonzero(changed.any(axis=1)), np.flatnonzero(changed.any(axis=0))
        if not len(rows):
            image, offset, milliseconds, options = self._pending
            self._pending = (image, offset, milliseconds + delay, options)
            return
        top, bottom, left, right = rows[0], rows[-1] + 1, columns[0], columns[-1] + 1
        # In the box, what did not change is transparent: the previous frame shows through, and
        # the runs of one index compress well.
        box = np.where(changed[top:bottom, left:right], indices[top:bottom, left:right], UNCHANGED)
        image = Image.fromarray(box.astype(np.uint8))
        image.putpalette(self._palette.getpalette())
        self._write_pending()
        self._previous = indices
        self._pending = (image, (int(left), int(top)), delay, {"transparency": UNCHANGED})

    def _write_pending(self) -> None:
        from PIL import GifImagePlugin

        if self._pending is not None:
            image, offset, milliseconds, options = self._pending
            chunks = GifImagePlugin.getdata(image, offset, duration=milliseconds, **options)
            self._stream.write(b"".join(chunks))
            self._pending = None

    def finish(self) -> None:
        try:
            self._write_pending()
            self._stream.write(b";")  # the trailer
            self._stream.flush()
            os.fsync(self._stream.fileno())
            self._stream.close()
            os.replace(self.temporary, self.path)
        except BaseException:
            self.abort()
            raise

    def abort(self) -> None:
        self._stream.close()
        with contextlib.suppress(OSError):
            os.remove(self.temporary)


def gif_delay(index: int, fps: float) -> int:
    """Milliseconds GIF frame `index` is shown at `fps`: whole hundredths of a second (all GIF can
    hold) whose running sum is frame k's true time k / fps rounded, so that the rounding does not
    add up (30 fps: 30, 30, 40, 30, 30, 40 ms, ...; 220 frames last 7.33 s, not 220 x 30 ms = 6.6 s).
    At least 20 ms, as browsers show shorter delays as 100 ms."""
    step = round(100 * (index + 1) / fps) - round(100 * index / fps)
    return 10 * max(2, step)


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
