"""A PNG written strip by strip, while the next strip is drawn: large outputs never held whole.

`PngStripWriter` takes horizontal strips of RGBA pixels (8 or 16 bits) from the top
down and writes one PNG: the header and metadata chunks, then the IDAT stream, filtered
and compressed as OpenCV's encoder does it (the Sub filter on every row, zlib level 1
with run-length matching) in a worker thread, so that compressing strip k overlaps the
GPU drawing strip k + 1 (zlib releases the GIL).  The file is a standard PNG of the same
pixels as `app.io.images.writing.encode_image` writes; its bytes differ (IDAT chunking).
"""

from __future__ import annotations

import struct
import zlib
from concurrent.futures import Future, ThreadPoolExecutor
from typing import BinaryIO

import numpy as np

from app.io.images.metadata import ImageMetadata
from app.io.images.writing import png_chunk, png_with_metadata

#: PNG colour type of RGBA.
_RGBA = 6
#: Largest IDAT chunk written.
_IDAT_BYTES = 1 << 20


class PngStripWriter:
    """Writes a PNG of (width, height) RGBA pixels to `stream`, strip by strip, top to bottom.

    Parameters
    ----------
    stream : binary file
        Where the PNG goes (a temporary file of `app.io.files.write_atomic`).
    size : tuple of int
        (width, height) in pixels.
    dtype : numpy dtype
        uint8 or uint16 samples.
    metadata : ImageMetadata, optional
        ICC profile and EXIF block, as chunks after the header.
    """

    def __init__(self, stream: BinaryIO, size: tuple[int, int], dtype, metadata: ImageMetadata | None = None):
        width, height = size
        self._stream = stream
        self._dtype = np.dtype(dtype)
        self._rows_left = height
        depth = 8 * self._dtype.itemsize
        header = b"\x89PNG\r\n\x1a\n" + png_chunk(
            b"IHDR", struct.pack(">IIBBBBB", width, height, depth, _RGBA, 0, 0, 0)
        )
        if metadata is not None and (metadata.icc_profile is not None or metadata.exif is not None):
            header = png_with_metadata(header, metadata)
        stream.write(header)
        self._compressor = zlib.compressobj(1, zlib.DEFLATED, 15, 8, zlib.Z_RLE)
        self._worker = ThreadPoolExecutor(max_workers=1)
        self._pending: Future | None = None

    def add(self, rows: np.ndarray) -> None:
        """Queue the next strip, RGBA of shape (r, width, 4); it is filtered and compressed in the worker.

        The worker reads `rows` later: the caller must not change them afterwards.
        """
        if rows.dtype != self._dtype or len(rows) > self._rows_left:
            raise ValueError(
                f"expected at most {self._rows_left} rows of {self._dtype}, got {rows.shape} {rows.dtype}"
            )
        self._rows_left -= len(rows)
        previous, self._pending = self._pending, None
        if previous is not None:
            self._write(previous.result())  # one strip in flight at a time: memory stays one strip
        self._pending = self._worker.submit(self._compressed, rows)

    def finish(self) -> None:
        """Write the rest of the stream and the end chunk; every row must have been added."""
        if self._rows_left:
            raise ValueError(f"{self._rows_left} rows of the PNG were never added")
        try:
            if self._pending is not None:
                self._write(self._pending.result())
            self._write(self._compressor.flush())
            self._stream.write(png_chunk(b"IEND", b""))
        finally:
            self._worker.shutdown()

    def close(self) -> None:
        """Stop the worker without finishing (after an error)."""
        self._worker.shutdown(cancel_futures=True)

    def _compressed(self, rows: np.ndarray) -> bytes:
        return self._compressor.compress(sub_filtered(rows))

    def _write(self, data: bytes) -> None:
        for start in range(0, len(data), _IDAT_BYTES):
            self._stream.write(png_chunk(b"IDAT", data[start : start + _IDAT_BYTES]))


def drawn_edges(mesh, positions: np.ndarray, view, image_size, backdrop: bool) -> np.ndarray:
    """The edges a drawing of the warp has, in output pixels: where pixels are partly covered.

    Parameters
    ----------
    mesh : core.Mesh
        Its boundary vertices, in the order of their curve parameters, bound the warp.
    positions : ndarray of shape (V, 2)
        The deformed vertices, image pixels.
    view : app.render.viewport.View
        Image pixels to output pixels.
    image_size : tuple of int
        (width, height) of the source image: the backdrop's sides, when it is drawn.
    backdrop : bool
        Whether the whole image is drawn under the warp; its sides are edges unless they fall
        on pixel boundaries (a view of scale 1 and whole offsets).

    Returns
    -------
    ndarray of shape (E, 2, 2)
        Segments, each two (x, y) ends.
    """
    order = mesh.boundary[np.argsort(mesh.boundary_parameters)]
    curve = positions[order] * view.scale + np.asarray(view.offset)
    segments = [np.stack([curve, np.roll(curve, -1, axis=0)], axis=1)]
    aligned = view.scale == 1 and all(float(offset).is_integer() for offset in view.offset)
    if backdrop and not aligned:
        width, height = image_size
        corners = np.array([[0, 0], [width, 0], [width, height], [0, height]]) * view.scale
        corners = corners + np.asarray(view.offset)
        segments.append(np.stack([corners, np.roll(corners, -1, axis=0)], axis=1))
    return np.concatenate(segments)


def crosses(segments: np.ndarray, box: tuple[int, int, int, int], margin: float = 2.0) -> bool:
    """Whether any of `segments` (E, 2, 2) may come within `margin` pixels of the tile `box`
    (left, top, width, height): conservative, by their bounding boxes."""
    left, top, width, height = box
    low, high = segments.min(axis=1), segments.max(axis=1)
    return bool(
        (
            (high[:, 0] >= left - margin)
            & (low[:, 0] <= left + width + margin)
            & (high[:, 1] >= top - margin)
            & (low[:, 1] <= top + height + margin)
        ).any()
    )


def encloses(segments: np.ndarray, point: tuple[float, float]) -> bool:
    """Whether `point` (x, y) lies inside the closed outline made of `segments` (E, 2, 2), in any order
    (holes too): an odd count of them crosses the ray from it towards +x."""
    x, y = point
    (x0, y0), (x1, y1) = segments[:, 0].T, segments[:, 1].T
    spans = (y0 > y) != (y1 > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        crossing = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
    return bool(np.count_nonzero(spans & (crossing > x)) % 2)


def sub_filtered(rows: np.ndarray) -> bytes:
    """PNG scanlines of RGBA `rows` (r, W, 4), uint8 or uint16 (stored big-endian), each with the
    Sub filter: a filter-type byte 1, then every byte minus the one a pixel before it (mod 256)."""
    count = len(rows)
    data = rows.astype(">u2", copy=False) if rows.dtype == np.uint16 else rows
    flat = np.ascontiguousarray(data).view(np.uint8).reshape(count, -1)
    pixel = 4 * rows.dtype.itemsize
    lines = np.empty((count, flat.shape[1] + 1), np.uint8)
    lines[:, 0] = 1
    lines[:, 1 : 1 + pixel] = flat[:, :pixel]
    np.subtract(flat[:, pixel:], flat[:, :-pixel], out=lines[:, 1 + pixel :])
    return lines.tobytes()
