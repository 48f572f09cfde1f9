"""Image files by their name's extension: PNG, TIFF, JPEG, WebP, with the input's depth and metadata.

`encode_image` turns RGBA pixels (8- or 16-bit, straight alpha) into the bytes of a
file: PNG (8/16-bit RGBA) and TIFF (8/16-bit RGBA, LZW) keep the depth, JPEG and WebP
are 8-bit.  OpenCV encodes the pixels; the ICC profile and the EXIF block of
`ImageMetadata` are then put into the file byte for byte (PNG ``iCCP``/``eXIf`` chunks,
JPEG APP2/APP1 segments, TIFF tags of its first IFD with the EXIF's offsets relocated;
WebP through Pillow, which writes both).  A
PNG without metadata is exactly OpenCV's, as it always was.  JPEG has no alpha: a
transparent output is refused, never flattened onto black.
"""

from __future__ import annotations

import io
import os
import struct
import sys
import warnings
import zlib
from pathlib import Path

import cv2
import numpy as np

from app.io.images.metadata import EXIF_PREFIX, TIFF_LAYOUT_TAGS, ImageMetadata, laid_out_exif

#: Output file name extensions and the format each writes.
OUTPUT_FORMATS = {
    ".png": "PNG",
    ".tif": "TIFF",
    ".tiff": "TIFF",
    ".jpg": "JPEG",
    ".jpeg": "JPEG",
    ".webp": "WebP",
}
#: Formats that store 16 bits per sample.
DEEP_FORMATS = ("PNG", "TIFF")
#: JPEG and WebP quality when none is given (0-100).
DEFAULT_QUALITY = 92
#: Largest payload of a JPEG segment (its length field counts itself).
_SEGMENT = 65533
#: Largest ICC piece of one JPEG APP2 segment ("ICC_PROFILE\0", sequence and count take 14 bytes).
_ICC_PIECE = _SEGMENT - 14


class TransparentOutputError(ValueError):
    """Pixels that are not opaque, to be written in a format without alpha."""


def output_format(path: str | os.PathLike) -> str:
    """The format the name of `path` asks for (``"PNG"``, ``"TIFF"``, ``"JPEG"``, ``"WebP"``).

    Raises
    ------
    ValueError
        For any other extension, naming the ones written.
    """
    suffix = Path(path).suffix.lower()
    if suffix not in OUTPUT_FORMATS:
        raise ValueError(f"the output file name must end in {', '.join(OUTPUT_FORMATS)}")
    return OUTPUT_FORMATS[suffix]


def has_alpha(kind: str) -> bool:
    """Whether the format `kind` stores transparency."""
    return kind != "JPEG"


def encode_image(
    pixels: np.ndarray,
    kind: str = "PNG",
    metadata: ImageMetadata | None = None,
    quality: int = DEFAULT_QUALITY,
    consume: bool = False,
) -> bytes:
    """The bytes of an image file of format `kind` holding `pixels` and `metadata`.

    Parameters
    ----------
    pixels : ndarray of shape (H, W, 4), uint8 or uint16
        RGBA, straight alpha, row 0 at the top.
    kind : str
        ``"PNG"``, ``"TIFF"``, ``"JPEG"`` or ``"WebP"`` (`output_format`).
    metadata : ImageMetadata, optional
        ICC profile and EXIF block to embed.
    quality : int
        JPEG and WebP quality, 1-100.
    consume : bool
        `pixels` may be overwritten (a JPEG is then encoded without a copy of them).

    Raises
    ------
    TransparentOutputError
        A JPEG of pixels that are not all opaque.
    """
    metadata = metadata or ImageMetadata()
    if kind not in DEEP_FORMATS:
        pixels = eight_bit(pixels)
    if kind == "WebP":
        return _webp(pixels, metadata, quality)
    if kind == "JPEG":
        if not opaque(pixels):
            raise TransparentOutputError(
                "JPEG has no transparency and the output has transparent pixels; give --background COLOR "
                "to fill them, or write a PNG"
            )
        ok, buffer = _jpeg(pixels, quality, consume)
    else:
        ok, buffer = cv2.imencode(
            ".png" if kind == "PNG" else ".tiff", cv2.cvtColor(pixels, cv2.COLOR_RGBA2BGRA)
        )
    if not ok:
        raise RuntimeError(f"OpenCV failed to encode a {kind}")
    data = buffer.tobytes()
    if kind == "TIFF":
        return tiff_with_metadata(data, metadata)
    if metadata.icc_profile is None and metadata.exif is None:
        return data
    return {"PNG": png_with_metadata, "JPEG": jpeg_with_metadata}[kind](data, metadata)


#: Rows of a JPEG's pixels converted to BGR at a time (`_jpeg`).
_PACKED_ROWS = 256


def _jpeg(pixels: np.ndarray, quality: int, consume: bool):
    """`cv2.imencode` of opaque RGBA uint8 `pixels` (H, W, 4) as JPEG, from a BGR copy; with
    `consume`, from BGR packed into the front of their own buffer, a row at a time (they are
    destroyed: no copy of 3 bytes a pixel, 0.3 GB at 100 megapixels; the same bytes)."""
    options = [cv2.IMWRITE_JPEG_QUALITY, int(quality)]
    if not (consume and pixels.flags.c_contiguous and pixels.flags.writeable):
        return cv2.imencode(".jpg", cv2.cvtColor(pixels, cv2.COLOR_RGBA2BGR), options)
    height, width = pixels.shape[:2]
    packed = pixels.reshape(-1)[: height * width * 3].reshape(height, width, 3)
    # Rows r0 to r1, converted before written, land before row r1's RGBA: never on rows unread.
    for top in range(0, height, _PACKED_ROWS):
        packed[top : top + _PACKED_ROWS] = cv2.cvtColor(pixels[top : top + _PACKED_ROWS], cv2.COLOR_RGBA2BGR)
    return cv2.imencode(".jpg", packed, options)


def opaque(pixels: np.ndarray) -> bool:
    """Whether every alpha of RGBA `pixels` (H, W, 4) is its type's maximum.

    C-contiguous native little-endian pixels are read as one unsigned integer each (alpha its
    highest bits), whose least must be at least alpha's maximum shifted there: one pass over the
    pixels, no mask of them (0.02 s rather than 0.1 s at 100 megapixels).
    """
    maximum = np.iinfo(pixels.dtype).max
    if pixels.size == 0:
        return True
    if pixels.flags.c_contiguous and pixels.dtype.isnative and sys.byteorder == "little":
        bits = 8 * pixels.dtype.itemsize
        whole = pixels.reshape(-1).view(np.uint32 if bits == 8 else np.uint64)
        return bool(whole.min() >= maximum << (3 * bits))
    return bool((pixels[..., 3] == maximum).all())


def eight_bit(pixels: np.ndarray) -> np.ndarray:
    """`pixels` as uint8: unchanged if they are, 16-bit values rounded to the nearest of 0-255."""
    if pixels.dtype == np.uint8:
        return pixels
    result = np.empty(pixels.shape, np.uint8)
    rows = max(1, (1 << 22) // max(1, pixels[0].size))  # a few MB at a time
    for top in range(0, len(pixels), rows):
        block = pixels[top : top + rows].astype(np.uint32)
        result[top : top + rows] = (block + 128) // 257
    return result


def png_chunk(kind: bytes, payload: bytes) -> bytes:
    """One PNG chunk: length, type, data and CRC."""
    return struct.pack(">I", len(payload)) + kind + payload + struct.pack(">I", zlib.crc32(kind + payload))


def png_with_metadata(data: bytes, metadata: ImageMetadata) -> bytes:
    """The PNG `data` with an ``iCCP`` and an ``eXIf`` chunk right after its header chunk."""
    end = 8 + 12 + struct.unpack(">I", data[8:12])[0]  # signature, then IHDR
    chunks = b""
    if metadata.icc_profile is not None:
        chunks += png_chunk(b"iCCP", b"ICC profile\x00\x00" + zlib.compress(metadata.icc_profile))
    if metadata.exif is not None:
        chunks += png_chunk(b"eXIf", metadata.exif)
    return data[:end] + chunks + data[end:]


def jpeg_with_metadata(data: bytes, metadata: ImageMetadata) -> bytes:
    """The JPEG `data` with the EXIF block (APP1) and the ICC profile (APP2 pieces) after its JFIF header."""
    position = 2
    if data[2:4] == b"\xff\xe0":  # keep the JFIF APP0 segment first
        position = 4 + struct.unpack(">H", data[4:6])[0]
    segments = b""
    if metadata.exif is not None and len(EXIF_PREFIX + metadata.exif) <= _SEGMENT:
        segments += _segment(0xE1, EXIF_PREFIX + metadata.exif)
    if metadata.icc_profile is not None:
        profile = metadata.icc_profile
        pieces = [profile[start : start + _ICC_PIECE] for start in range(0, len(profile), _ICC_PIECE)]
        if len(pieces) <= 255:
            for number, piece in enumerate(pieces, 1):
                segments += _segment(0xE2, b"ICC_PROFILE\x00" + bytes((number, len(pieces))) + piece)
    return data[:position] + segments + data[position:]


def _segment(marker: int, payload: bytes) -> bytes:
    return bytes((0xFF, marker)) + struct.pack(">H", len(payload) + 2) + payload


#: TIFF tags written: the ICC profile (UNDEFINED bytes), what the fourth sample is.
_ICC_TAG, _EXTRA_SAMPLES_TAG = 34675, 338
#: ExtraSamples value of straight (unassociated) alpha.
_STRAIGHT_ALPHA = 2


def tiff_with_metadata(data: bytes, metadata: ImageMetadata) -> bytes:
    """OpenCV's RGBA TIFF `data` with its first IFD rewritten at the end, tags added: the fourth
    sample is straight alpha (ExtraSamples; OpenCV leaves it unspecified, which other programs do
    not show as transparency), the ICC profile if there is one, and the EXIF block's tags
    (`_tiff_exif`): a TIFF holds EXIF as tags of its first IFD and sub-IFDs it points to.
    """
    order = "<" if data[:2] == b"II" else ">"
    (first,) = struct.unpack(order + "I", data[4:8])
    (count,) = struct.unpack(order + "H", data[first : first + 2])
    entries = [data[first + 2 + 12 * index : first + 14 + 12 * index] for index in range(count)]
    (following,) = struct.unpack(order + "I", data[first + 2 + 12 * count : first + 6 + 12 * count])
    padded = data + b"\x00" * (len(data) % 2)  # values start on a word boundary
    profile_at = len(padded)
    profile = b""
    entries = [entry for entry in entries if struct.unpack(order + "H", entry[:2])[0] != _EXTRA_SAMPLES_TAG]
    entries.append(struct.pack(order + "HHIHH", _EXTRA_SAMPLES_TAG, 3, 1, _STRAIGHT_ALPHA, 0))
    if metadata.icc_profile is not None:
        profile = metadata.icc_profile + b"\x00" * (len(metadata.icc_profile) % 2)
        entries.append(struct.pack(order + "HHII", _ICC_TAG, 7, len(metadata.icc_profile), profile_at))
    exif_at = profile_at + len(profile)
    exif = b""
    if metadata.exif is not None:
        present = {struct.unpack(order + "H", entry[:2])[0] for entry in entries}
        exif, exif_entries = _tiff_exif(metadata.exif, data[:8], exif_at, present)
        entries += exif_entries
    entries.sort(key=lambda entry: struct.unpack(order + "H", entry[:2])[0])
    directory_at = exif_at + len(exif)
    directory = (
        struct.pack(order + "H", len(entries)) + b"".join(entries) + struct.pack(order + "I", following)
    )
    header = data[:4] + struct.pack(order + "I", directory_at)
    return header + padded[8:] + profile + exif + directory


def _tiff_exif(block: bytes, head: bytes, at: int, present: set[int]) -> tuple[bytes, list[bytes]]:
    """(bytes to place at offset `at` of a TIFF of header `head`, entries (12 bytes each) for its
    first IFD) that carry the EXIF `block` (a TIFF structure, orientation already 1).

    Pillow parses the block and `laid_out_exif` lays its tags out again at `at`, so that every
    offset is relocated; the tags the TIFF already has (`present`) and those of
    `TIFF_LAYOUT_TAGS` are left out.  The bytes start with the count and entries of that
    directory, which nothing points to.  A block Pillow cannot parse gives nothing.
    """
    from PIL import Image

    exif = Image.Exif()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # Pillow warns of a corrupt block, then gives up on it
            exif.load(EXIF_PREFIX + block)
            laid_out, count = laid_out_exif(exif, TIFF_LAYOUT_TAGS | present, head, at)
    except Exception:  # Pillow raises many kinds on a malformed block: the output goes without it
        return b"", []
    return laid_out, [laid_out[2 + 12 * index : 14 + 12 * index] for index in range(count)]


def _webp(pixels: np.ndarray, metadata: ImageMetadata, quality: int) -> bytes:
    """WebP bytes through Pillow (lossy at `quality`; RGB when opaque), with the profile and EXIF."""
    from PIL import Image

    image = Image.fromarray(np.ascontiguousarray(pixels[..., :3]) if opaque(pixels) else pixels)
    options = {"quality": int(quality)}
    if metadata.icc_profile is not None:
        options["icc_profile"] = metadata.icc_profile
    if metadata.exif is not None:
        options["exif"] = metadata.exif
    stream = io.BytesIO()
    image.save(stream, format="WEBP", **options)
    return stream.getvalue()
