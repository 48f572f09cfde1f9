"""Reading and writing the files of the command line and the viewer.

Cage files are JSON ``{"control_points": [[x, y], ...]}`` in image pixels (x to
the right, y down, origin at the image's top-left corner); session files are read and written
by `app.io.session`, with the JSON and cage helpers here.  Every
reader validates its input and raises `InputError` with one line naming the file
and what is wrong in it; every writer is atomic (a temporary file in the same
directory, then `os.replace`), so a failed or interrupted write leaves an existing
file untouched.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import stat
from collections.abc import Iterable, Iterator
from numbers import Real
from pathlib import Path

import cv2
import numpy as np

from app.console import captured_c_stderr, note
from app.io.image_header import MAX_IMAGE_PIXELS, ImageHeader, image_header
from app.io.images import (
    DEFAULT_QUALITY,
    OUTPUT_FORMATS,
    ImageMetadata,
    Photo,
    encode_image,
    oriented,
    output_format,
    read_metadata,
    rgba_pixels,
    straight_rgba_tiff,
)
from app.io.images.colour_profiles import matched_profile
from app.io.images.tiles import PngStripWriter
from core import MAX_CONTROL_POINTS, NAME_MAX, as_points, too_many_control_points, write_atomically

#: Largest image file read into memory.
MAX_IMAGE_FILE_BYTES = 1 << 30
#: Largest JSON file (cage, session, script, data) read: parsed, it takes about 10 times that.
MAX_JSON_FILE_BYTES = 1 << 27
#: The extensions of the image files written (`write_image`): PNG, TIFF, JPEG, WebP.
IMAGE_SUFFIXES = tuple(OUTPUT_FORMATS)
#: Largest cage coordinate, in pixels: beyond it float64 has no sub-pixel precision left.
MAX_COORDINATE = 1e15


class InputError(ValueError):
    """Bad input from a file or the command line: one line saying what and where."""


@contextlib.contextmanager
def reported_as_input(where: str) -> Iterator[None]:
    """Turn a `ValueError` of the block (bad cage, kernel, mesh size, ...) into an `InputError`.

    `core` raises `ValueError` with a message a person can act on; this adds
    where the offending input came from.
    """
    try:
        yield
    except InputError:
        raise
    except ValueError as error:
        raise InputError(f"{where}: {error}") from None


def cage_curve(control_points: np.ndarray, where: str, samples_per_segment: int | None = None):
    """`core.ClosedBSpline` of a cage, or `InputError` naming `where` (self-intersection, ...).

    First, before the curve's own checks (which take time in the number of control
    points), the cage's boundary samples at `samples_per_segment` per span (the
    kernels' default if None) must be within `core.validation.MAX_BOUNDARY_SAMPLES`.
    """
    import core
    from core import DEFAULT_SAMPLES_PER_SEGMENT, checked_samples_per_segment

    per = DEFAULT_SAMPLES_PER_SEGMENT if samples_per_segment is None else samples_per_segment
    with reported_as_input(where):
        checked_samples_per_segment(per, len(control_points))
        return core.ClosedBSpline(control_points)


# -- generic ------------------------------------------------------------------


def write_atomic(path: str | os.PathLike, data: bytes) -> None:
    """Write `data` to `path` through a temporary file in the same directory and `os.replace`.

    Temporaries left by a killed process are removed first (`core.storage.atomic_write`);
    a new file gets the mode the umask gives, a replaced one keeps its mode.

    Raises
    ------
    InputError
        If the file cannot be written; `path` is then unchanged.
    """
    path = Path(path)
    check_writable(path)
    try:
        write_atomically(path, lambda stream: stream.write(data))
    except OSError as error:
        raise InputError(f"{path}: cannot write ({error.strerror or error})") from None


def check_writable(path: str | os.PathLike, *, suffix: str | tuple[str, ...] | None = None) -> None:
    """Raise `InputError` early if `path` obviously cannot be written (before long work).

    Parameters
    ----------
    path : path-like
        The output file.
    suffix : str or tuple of str, optional
        Required file name extension, e.g. ``".png"``, or one of several (`IMAGE_SUFFIXES`),
        compared case-insensitively.
    """
    path = Path(path)
    suffixes = (suffix,) if isinstance(suffix, str) else suffix
    if suffixes is not None and path.suffix.lower() not in suffixes:
        raise InputError(f"{path}: the output file name must end in {', '.join(suffixes)}")
    check_name_length(path)
    try:
        if path.is_dir():
            raise InputError(f"{path}: cannot write, it is a directory")
        parent = path.parent
        if not parent.is_dir():
            raise InputError(f"{path}: cannot write, directory {parent} does not exist")
        if not os.access(parent, os.W_OK | os.X_OK) or (path.exists() and not os.access(path, os.W_OK)):
            raise InputError(f"{path}: cannot write, permission denied")
    except OSError as error:  # a path too long, a loop of symbolic links, ...
        raise InputError(f"{path}: cannot write ({error.strerror or error})") from None


def check_name_length(path: str | os.PathLike) -> None:
    """`InputError` if the last part of `path` is longer than a file name may be (`NAME_MAX` bytes)."""
    length = len(os.fsencode(Path(path).name))
    if length > NAME_MAX:
        raise InputError(f"{path}: the file name is {length} bytes long; at most {NAME_MAX} are allowed")


def refuse_overwriting_inputs(output: str | os.PathLike, inputs: dict[str, str | os.PathLike | None]) -> None:
    """`InputError` if `output` is one of the `inputs` (what it is -> its path, None if not given):
    the same file, also through another name or a link.  An output that does not exist yet is none."""
    for what, path in inputs.items():
        if path is not None and same_file(output, path):
            raise InputError(f"{output}: is the {what}; give another output, inputs are never overwritten")


def same_file(first: str | os.PathLike, second: str | os.PathLike) -> bool:
    """Whether both paths name one existing file."""
    try:
        return os.path.samefile(first, second)
    except (OSError, ValueError):  # one of them does not exist (or cannot be a path)
        return False


def read_json(path: str | os.PathLike):
    """Parse a JSON file; `InputError` with the file name (and line) if that fails."""
    path = Path(path)
    # utf-8-sig: a byte order mark, which some editors write, is not part of the JSON text.
    text = _read_bytes(path, MAX_JSON_FILE_BYTES).decode("utf-8-sig", errors="replace")
    try:
        return json.loads(text)
    except json.JSONDecodeError as error:
        raise InputError(
            f"{path}: not valid JSON ({error.msg} at line {error.lineno}, column {error.colno})"
        ) from None
    except RecursionError:
        raise InputError(f"{path}: cannot read the JSON (arrays or objects nested too deeply)") from None
    except ValueError as error:  # e.g. an integer of more digits than Python converts
        raise InputError(f"{path}: cannot read the JSON ({str(error).split(':')[0]})") from None


#: A list of numbers that `json.dumps(indent=...)` spread over lines (raw newlines occur in no JSON string).
_NUMBER_LIST = re.compile(r"\[\n\s*(-?[0-9][0-9.eE+-]*(?:,\n\s*-?[0-9][0-9.eE+-]*)*)\n\s*\]")


def json_text(value) -> str:
    """Indented JSON text of `value`, each list of numbers (an [x, y] pair) on one line."""
    # allow_nan=False: Python would write NaN, which is not JSON.
    text = json.dumps(value, indent=2, allow_nan=False)
    return _NUMBER_LIST.sub(
        lambda match: f"[{', '.join(n.strip() for n in match.group(1).split(','))}]", text
    )


def write_json(path: str | os.PathLike, value) -> None:
    """Write `value` as indented JSON (number lists on one line), atomically."""
    write_atomic(path, (json_text(value) + "\n").encode("utf-8"))


# -- cages --------------------------------------------------------------------


def cage_points(value, where: str) -> np.ndarray:
    """Control points of a cage object ``{"control_points": [[x, y], ...]}``.

    Parameters
    ----------
    value : object
        Parsed JSON.
    where : str
        Where the object comes from, for messages (e.g. ``"cage.json"`` or
        ``"session.json: target"``).

    Returns
    -------
    ndarray of shape (n, 2), float64

    Raises
    ------
    InputError
        Not an object with a ``control_points`` list of number pairs, non-finite
        values, or fewer than 3 points.  Whether the curve is simple is
        checked by `core.ClosedBSpline`.
    """
    if not isinstance(value, dict):
        raise InputError(f'{where}: expected an object with "control_points", got {json_type(value)}')
    if "control_points" not in value:
        raise InputError(f'{where}: missing "control_points"')
    points = value["control_points"]
    if not isinstance(points, list):
        raise InputError(f'{where}: "control_points" must be a list of [x, y] pairs, got {json_type(points)}')
    if len(points) > MAX_CONTROL_POINTS:  # before the checks of each point, which take time
        raise InputError(f"{where}: {too_many_control_points(len(points))}")
    for index, point in enumerate(points):
        # bool is an int in Python, but `true` is never a coordinate.
        if not (isinstance(point, list) and len(point) == 2 and all(_is_number(c) for c in point)):
            raise InputError(
                f"{where}: control_points[{index}] must be a pair of numbers [x, y], got {shown(point)}"
            )
        if any(_out_of_range(c) for c in point):
            raise InputError(
                f"{where}: control_points[{index}] = {shown(point)} is out of range: coordinates must "
                f"lie within +-{MAX_COORDINATE:g} pixels"
            )
    try:
        return as_points(points, "control_points", min_count=3)
    except ValueError as error:
        raise InputError(f"{where}: {error}") from None


#: The file name extensions of cage files: JSON, or an SVG path (`app.io.svg_cages`).
CAGE_SUFFIXES = (".json", ".svg")


def read_cage(path: str | os.PathLike) -> np.ndarray:
    """Control points, ndarray of shape (n, 2), of the cage file at `path` (JSON or SVG).

    A fitted SVG path leaves a `note` of its fit error."""
    control_points, remark = read_cage_file(path)
    if remark is not None:
        note(remark)
    return control_points


def read_cage_file(path: str | os.PathLike) -> tuple[np.ndarray, str | None]:
    """Control points (n, 2) of the cage file at `path`, and what a reader should know of them.

    A JSON cage file, or an SVG file whose first closed path is the cage
    (`app.io.svg_cages`): exact when it is a chain of quadratic Béziers, fitted
    otherwise, and then the remark says how closely (None for an exact cage).
    """
    if Path(path).suffix.lower() != ".svg":
        return cage_points(read_json(path), str(path)), None
    from app.io.svg_cages import FIT_TOLERANCE, svg_cage

    data = _read_bytes(Path(path), MAX_JSON_FILE_BYTES)
    try:
        cage = svg_cage(data)
    except ValueError as error:
        raise InputError(f"{path}: {error}") from None
    points = cage_points({"control_points": cage.control_points.tolist()}, str(path))
    if cage.fit_error is None:
        return points, None
    return points, (
        f"{path}: the path is not a quadratic B-spline; fitted {len(points)} control points within "
        f"{cage.fit_error:.2f} px (at most {FIT_TOLERANCE:g})"
    )


def write_cage(
    path: str | os.PathLike, control_points: np.ndarray, image_size: tuple[int, int] | None = None
) -> None:
    """Write a cage file atomically: JSON (coordinates rounded to 1/1000 pixel), or by an ``.svg``
    name the exact chain of quadratic Béziers (`app.io.svg_cages.svg_text`) over an image of
    `image_size` (width, height; by default the cage's extent)."""
    points = np.asarray(control_points, dtype=np.float64)
    if Path(path).suffix.lower() == ".svg":
        from app.io.svg_cages import svg_text

        width, height = image_size or np.ceil(np.maximum(points.max(axis=0), 1.0))
        write_atomic(path, svg_text(points, width, height).encode("utf-8"))
        return
    write_json(path, {"control_points": np.round(points, 3).tolist()})


# -- kernels -------------------------------------------------------------------


def kernel_names() -> tuple[str, ...]:
    """Every kernel name `core.mesh_basis_functions` takes: the point kernels and the mesh-based ones."""
    import core

    return (*core.KERNELS, *core.COMPLEX_KERNELS, *core.MESH_ONLY_KERNELS)


# -- images -------------------------------------------------------------------


def read_image(path: str | os.PathLike) -> np.ndarray:
    """The pixels of an image file: `read_photo`'s, without the metadata.

    Returns
    -------
    ndarray of shape (H, W, 4), uint8 or uint16 (the file's depth)
        Straight alpha (the type's maximum where the file has none), row 0 at the top of the
        displayed picture (EXIF orientation applied).
    """
    return read_photo(path).pixels


def read_photo(path: str | os.PathLike) -> Photo:
    """Decode an image file (PNG, JPEG, TIFF, WebP, ... anything OpenCV reads) as RGBA and its metadata.

    The header is read first: an image of more than `MAX_IMAGE_PIXELS` pixels is
    refused before anything is allocated for it.  8- and 16-bit samples are kept; grey,
    palette and CMYK pictures become RGB; the EXIF orientation is applied, so that cage
    coordinates are in the frame every viewer shows; the ICC profile and EXIF block are
    kept for writing (`write_image`).  What is dropped or ignored (a malformed EXIF
    block, the other pages of a TIFF) is a note.

    Returns
    -------
    Photo
        ``pixels`` of shape (H, W, 4), uint8 or uint16, straight alpha, row 0 at the top.

    Raises
    ------
    InputError
        Missing, unreadable, empty, corrupt, unsupported or too large file.
    MemoryError
        The machine cannot allocate the decoded image.
    """
    path = Path(path)
    data = _read_bytes(path, limit=MAX_IMAGE_FILE_BYTES)
    header = image_header(data)
    if header is not None:
        check_image_size(header, path)
    info = read_metadata(data)
    notes = list(info.notes)
    with reported_as_input(str(path)):
        converted, metadata = matched_profile(data, info.mode, info.metadata, notes)
        # An 8-bit RGBA TIFF: OpenCV reads it through libtiff's RGBA interface, which premultiplies
        # a straight alpha; Pillow does not.
        tiff_rgba = header is not None and header.format == "TIFF" and info.mode == "RGBA"
        if converted is None:
            decoded = straight_rgba_tiff(data) if tiff_rgba else _decode(data, path)
        del data  # the encoded file is no longer needed: not held while the pixels are converted
        if converted is None:
            converted = decoded if tiff_rgba else rgba_pixels(decoded)
        pixels = oriented(converted, info.orientation)
    for line in notes:
        note(f"{path}: {line}")
    return Photo(pixels, metadata, tuple(notes))


def image_metadata(path: str | os.PathLike) -> ImageMetadata:
    """The ICC profile and EXIF block of the image file `path` (orientation reset to 1), without
    decoding its pixels; empty if the file cannot be read."""
    try:
        data = _read_bytes(Path(path), MAX_IMAGE_FILE_BYTES)
    except InputError:
        return ImageMetadata()
    info = read_metadata(data)
    return matched_profile(data, info.mode, info.metadata, [], convert=False)[1]


def check_image_size(header: ImageHeader, path: str | os.PathLike) -> None:
    """`InputError` if the image `header` declares has more than `MAX_IMAGE_PIXELS` pixels."""
    if header.pixels > MAX_IMAGE_PIXELS:
        raise InputError(
            f"{path}: the {header.format} image is {header.width}x{header.height} pixels "
            f"({header.pixels / 1e6:.0f} megapixels); at most {MAX_IMAGE_PIXELS / 1e6:.0f} megapixels "
            "can be processed"
        )


def _decode(data: bytes, path: Path) -> np.ndarray:
    """OpenCV's decoding of `data`, with its complaints as one `InputError` line."""
    with captured_c_stderr() as messages:
        try:
            image = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
        except cv2.error as error:
            if error.code == cv2.Error.StsNoMem:
                raise MemoryError(f"decoding {path}: {error.err}") from None
            if "CV_IO_MAX_IMAGE_PIXELS" in error.err:
                raise InputError(
                    f"{path}: the image has more than {MAX_IMAGE_PIXELS / 1e6:.0f} megapixels, the most "
                    "that can be processed"
                ) from None
            image, messages = None, [*messages, error.err]
    if image is None:
        reason = "the file is cut short" if _cut_short(data) else _decoder_reason(messages)
        raise InputError(f"{path}: cannot decode the image{f' ({reason})' if reason else ''}")
    return image


def encode_png(image: np.ndarray, metadata: ImageMetadata | None = None) -> bytes:
    """PNG bytes of an RGBA image of shape (H, W, 4), uint8 or uint16 (kept), row 0 at the top,
    with the ICC profile and EXIF block of `metadata` if given."""
    return encode_image(image, "PNG", metadata)


def write_png(path: str | os.PathLike, image: np.ndarray, metadata: ImageMetadata | None = None) -> None:
    """Write an RGBA image of shape (H, W, 4), uint8 or uint16, as PNG, atomically."""
    write_atomic(path, encode_png(image, metadata))


def write_image(
    path: str | os.PathLike,
    image: np.ndarray,
    metadata: ImageMetadata | None = None,
    quality: int = DEFAULT_QUALITY,
    consume: bool = False,
) -> None:
    """Write an RGBA image (H, W, 4), uint8 or uint16, in the format of `path`'s extension, atomically;
    with `consume`, `image` may be overwritten on the way (`app.io.images.encode_image`).

    PNG and TIFF keep 16 bits; JPEG and WebP are 8-bit at `quality`.  The ICC profile and
    EXIF block of `metadata` are embedded (`app.io.images.writing`).

    Raises
    ------
    InputError
        An extension not written, or transparent pixels for a JPEG: nothing is written.
    """
    with reported_as_input(str(path)):
        data = encode_image(image, output_format(path), metadata, quality, consume)
    write_atomic(path, data)


def write_png_strips(
    path: str | os.PathLike,
    size: tuple[int, int],
    dtype,
    strips: Iterable[tuple[int, np.ndarray]],
    metadata: ImageMetadata | None = None,
) -> None:
    """Write a PNG of (width, height) RGBA pixels from its horizontal strips, atomically.

    Each strip (top row, ndarray of shape (r, width, 4) of `dtype`) is compressed while the
    next one is made (`app.io.images.tiles.PngStripWriter`): the whole image is never in memory.
    """
    path = Path(path)
    check_writable(path)

    def write(stream) -> None:
        writer = PngStripWriter(stream, size, dtype, metadata)
        try:
            for _, rows in strips:
                writer.add(rows)
            writer.finish()
        except BaseException:
            writer.close()
            raise

    try:
        write_atomically(path, write)
    except OSError as error:
        raise InputError(f"{path}: cannot write ({error.strerror or error})") from None


def _read_bytes(path: Path, limit: int) -> bytes:
    """The bytes of the regular file at `path`, at most `limit` of them, or `InputError`.

    The file is opened without blocking and refused unless it is a regular file (a
    FIFO would block forever, ``/dev/zero`` never ends), and its size is checked
    while reading, so a file that grows meanwhile cannot exhaust memory either.
    """
    try:
        descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except OSError as error:
        raise InputError(f"{path}: cannot read ({error.strerror or error})") from None
    mode = os.fstat(descriptor).st_mode
    if not stat.S_ISREG(mode):
        os.close(descriptor)
        if stat.S_ISDIR(mode):
            raise InputError(f"{path}: is a directory, not a file")
        raise InputError(f"{path}: is {_file_kind(mode)}, not a regular file")
    with os.fdopen(descriptor, "rb") as stream:
        size = os.fstat(descriptor).st_size
        if size <= limit:
            try:
                data = _read_at_most(stream, limit + 1, size)
            except OSError as error:
                raise InputError(f"{path}: cannot read ({error.strerror or error})") from None
            size = max(size, len(data))
    if size > limit:
        raise InputError(
            f"{path}: the file is {size / 2**20:.0f} MiB{' or more' * (size == limit + 1)}; "
            f"at most {limit / 2**20:.0f} MiB can be read"
        )
    if not data:
        raise InputError(f"{path}: the file is empty")
    return data


def _read_at_most(stream, most: int, expected: int) -> bytes:
    """Up to `most` bytes of `stream`: first the `expected` size and one more (one allocation for
    a file that does not change), then in chunks, so memory follows what is really there."""
    parts, total, want = [], 0, expected + 1
    while total < most:
        part = stream.read(min(want, most - total))
        if not part:
            break
        parts.append(part)
        total += len(part)
        want = 1 << 20
    return b"".join(parts)


def _file_kind(mode: int) -> str:
    """What a file that is not regular is, for messages: "a FIFO", "a character device", ..."""
    for test, kind in (
        (stat.S_ISFIFO, "a FIFO (named pipe)"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    ):
        if test(mode):
            return kind
    return "a special file"


def _cut_short(data: bytes) -> bool:
    """Whether `data` is a PNG or JPEG file that ends before its format's end marker (PNG's IEND
    chunk, JPEG's EOI), as a file cut short by a failed copy or download does."""
    if data.startswith(b"\x89PNG\r\n\x1a\n"):
        return b"IEND" not in data[-12:]
    if data.startswith(b"\xff\xd8"):
        return not data.rstrip(b"\x00").endswith(b"\xff\xd9")
    return False


def _decoder_reason(messages: list[str]) -> str:
    """The most specific decoder message, without OpenCV's log prefix."""
    for line in reversed(messages):
        line = line.strip()
        if line.startswith("[") and "]" in line:
            line = line.split("]", 1)[1].strip()
            # OpenCV's log lines read "global file.cpp:123 function message".
            parts = line.split(" ", 3)
            line = parts[3] if len(parts) == 4 and parts[0] == "global" else line
        if line:
            return line.removeprefix("libpng error: ")
    return ""


def _is_number(value) -> bool:
    return isinstance(value, Real) and not isinstance(value, bool)


def finite_number(value) -> float | None:
    """`value` as a float if it is a JSON number (not a boolean) that is finite as a float, else None.

    JSON integers have any number of digits: one beyond float's range (a 401-digit
    integer) is not finite, like 1e999, instead of an `OverflowError`.
    """
    if not _is_number(value):
        return None
    try:
        number = float(value)
    except OverflowError:
        return None
    return number if math.isfinite(number) else None


def _out_of_range(value: Real) -> bool:
    """A coordinate beyond +-MAX_COORDINATE (integers of any size compare exactly; NaN and
    infinities are left to the finiteness check, which names them)."""
    return abs(value) > MAX_COORDINATE and not (isinstance(value, float) and math.isinf(value))


def shown(value, limit: int = 60) -> str:
    """`repr` of a JSON value, shortened to one readable piece of a line."""
    text = repr(value)
    return text if len(text) <= limit else f"{text[: limit - 3]}..."


def json_type(value) -> str:
    names = {dict: "an object", list: "a list", str: "a string", bool: "a boolean", type(None): "null"}
    return names.get(type(value), "a number")
