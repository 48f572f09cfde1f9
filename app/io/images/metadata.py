"""What a photograph carries besides its pixels: the ICC colour profile, the EXIF block and its orientation.

`read_metadata` reads them from the file's headers through Pillow (which parses the
headers only, never the pixels); `oriented` turns decoded pixels from the file's stored
frame into the frame every viewer shows (EXIF orientation 1-8), so that cage
coordinates are in the displayed frame; `ImageMetadata.exif` is the EXIF block with its
orientation reset to 1, ready to be written with the displayed pixels.  Damaged
metadata never stops a read: it is dropped with a note.
"""

from __future__ import annotations

import io
import struct
import warnings
import zlib
from dataclasses import dataclass

import numpy as np

from app.io.images.colour_profiles import cut_short

#: Largest ICC profile carried from input to output; a larger one is dropped with a note.
MAX_ICC_BYTES = 16 << 20
#: The EXIF tag of the orientation (a SHORT in the first IFD).
ORIENTATION_TAG = 0x0112
#: The TIFF tag of a TIFF's description of itself.
_IMAGE_DESCRIPTION = 270
#: The TIFF tag of the bits of each sample.
_BITS_PER_SAMPLE = 258
#: The first bytes of every PNG file.
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: The marker that precedes the EXIF block in JPEG APP1 segments (and in Pillow's ``info["exif"]``).
EXIF_PREFIX = b"Exif\x00\x00"
#: Tags of a TIFF's first IFD that lay out its pixels (sizes, samples, strips and tiles,
#: compression, a JPEG thumbnail) or carry its ICC profile: not EXIF, in either direction.
TIFF_LAYOUT_TAGS = frozenset(
    (256, 257, 258, 259, 262, 273, 277, 278, 279, 284, 317, 320, 322, 323, 324, 325, 338, 339, 513, 514)
    + (530, 531, 532, 34675)
)
#: The sub-IFDs an EXIF block's first IFD points to (Exif, GPS), and the maker's notes in the
#: Exif IFD: private bytes that may hold offsets into the file they came from.
_SUB_IFDS, _MAKER_NOTE = (34665, 34853), 37500


@dataclass(frozen=True)
class ImageMetadata:
    """The metadata of an image that is written back with its warped pixels.

    Attributes
    ----------
    icc_profile : bytes or None
        The embedded ICC profile, byte for byte.
    exif : bytes or None
        The EXIF block (a TIFF structure, without the ``Exif\\0\\0`` prefix), its orientation set to 1:
        the pixels it goes with are already in the displayed frame.
    """

    icc_profile: bytes | None = None
    exif: bytes | None = None


@dataclass(frozen=True)
class FileInfo:
    """What `read_metadata` finds in a file's headers.

    Attributes
    ----------
    metadata : ImageMetadata
        What is carried over to an output.
    orientation : int
        EXIF orientation, 1 to 8 (1 when absent or unusable).
    mode : str or None
        Pillow's pixel mode (``"RGB"``, ``"CMYK"``, ``"P"``, ``"I;16"``...; ``"RGBA;16"`` for a
        16-bit RGBA TIFF); None if Pillow cannot open the file.
    notes : tuple of str
        One line each about what was dropped or ignored (a damaged profile, a second TIFF page...).
    """

    metadata: ImageMetadata
    orientation: int = 1
    mode: str | None = None
    notes: tuple[str, ...] = ()


def read_metadata(data: bytes) -> FileInfo:
    """The ICC profile, EXIF block and orientation in the headers of the image file `data`.

    Parameters
    ----------
    data : bytes
        The whole file (PNG, JPEG, TIFF, WebP; other formats give empty metadata).
    """
    from PIL import Image

    notes: list[str] = []
    if data.startswith(PNG_SIGNATURE):
        # Read here, not by Pillow: it refuses a profile over 1 MB and then the whole header.
        icc, exif = png_metadata(data, notes)
        exif, orientation = _exif(exif, notes) if exif else (None, 1)
        return FileInfo(ImageMetadata(icc, exif), orientation, None, tuple(notes))
    try:
        with warnings.catch_warnings():
            # The size was checked against app.io.image_header.MAX_IMAGE_PIXELS before; Pillow's own
            # limit is lower and warns about a 100-megapixel photograph (it refuses only beyond
            # twice its limit, more than MAX_IMAGE_PIXELS).
            warnings.simplefilter("ignore")
            image = Image.open(io.BytesIO(data))
            info, mode, kind = dict(image.info), image.mode, image.format
            frames = getattr(image, "n_frames", 1) if kind == "TIFF" else 1
            tiff_orientation = image.tag_v2.get(ORIENTATION_TAG) if kind == "TIFF" else None
            tiff_exif = _tiff_exif(image) if kind == "TIFF" else None
            if kind == "TIFF" and mode == "RGBA" and image.tag_v2.get(_BITS_PER_SAMPLE) != (8, 8, 8, 8):
                mode = "RGBA;16"  # Pillow calls 16-bit RGBA "RGBA" too (it would read 8 bits of it)
    except Exception:  # Pillow raises many kinds; OpenCV's decoder then says what is wrong
        return FileInfo(ImageMetadata())
    if frames > 1:
        notes.append(f"the TIFF has {frames} pages; only the first is read")
    icc = _icc_profile(info.get("icc_profile"), notes)
    exif, orientation = None, 1
    if kind == "TIFF":
        # A TIFF's EXIF is the tags of its first IFD that do not lay out its pixels.
        orientation = _checked_orientation(tiff_orientation, notes)
        exif = _exif(tiff_exif, [])[0] if tiff_exif else None  # its orientation noted above
    elif info.get("exif"):
        exif, orientation = _exif(bytes(info["exif"]), notes)
    return FileInfo(ImageMetadata(icc, exif), orientation, mode, tuple(notes))


def png_metadata(data: bytes, notes: list[str]) -> tuple[bytes | None, bytes | None]:
    """The ICC profile (``iCCP``, decompressed) and EXIF block (``eXIf``) of the PNG `data`.

    A profile of more than `MAX_ICC_BYTES` is not decompressed beyond that: dropped with a note.
    """
    icc = exif = None
    position = len(PNG_SIGNATURE)
    while position + 8 <= len(data):
        (length,) = struct.unpack(">I", data[position : position + 4])
        kind, payload = data[position + 4 : position + 8], data[position + 8 : position + 8 + length]
        position += 12 + length
        if kind == b"IDAT":  # the metadata chunks come before the pixels
            break
        if kind == b"eXIf":
            exif = payload
        elif kind == b"iCCP" and b"\x00" in payload[:80]:
            compressed = payload[payload.index(b"\x00") + 2 :]
            inflater = zlib.decompressobj()
            try:
                profile = inflater.decompress(compressed, MAX_ICC_BYTES + 1)
            except zlib.error:
                notes.append("its ICC profile cannot be decompressed; dropped")
                continue
            if len(profile) > MAX_ICC_BYTES:
                notes.append(f"its ICC profile is more than {MAX_ICC_BYTES >> 20} MiB; dropped")
                continue
            icc = _icc_profile(profile, notes)
    return icc, exif


def _icc_profile(profile, notes: list[str]) -> bytes | None:
    """The profile if it is one that can be carried, else None with a note."""
    if not profile:
        return None
    profile = bytes(profile)
    if len(profile) > MAX_ICC_BYTES:
        notes.append(
            f"its ICC profile is {len(profile) / 2**20:.0f} MiB, more than {MAX_ICC_BYTES >> 20} MiB; dropped"
        )
        return None
    # An ICC profile starts with its own size and has the signature "acsp" at byte 36.
    if len(profile) < 128 or profile[36:40] != b"acsp":
        notes.append("its ICC profile is not a valid profile (no 'acsp' signature); carried over unchanged")
        return profile
    declared = cut_short(profile)
    if declared is not None:
        notes.append(
            f"its ICC profile is cut short ({len(profile)} of the {declared} bytes it declares); dropped"
        )
        return None
    return profile


def laid_out_exif(exif, leave_out: frozenset[int] | set[int], head: bytes, at: int) -> tuple[bytes, int]:
    """The first IFD of `exif` (a Pillow ``Image.Exif``) laid out anew at byte `at` of a TIFF whose
    header is `head` (8 bytes; its byte order is used): (its bytes, of even length, its number of
    entries).

    Every value that does not fit in its entry, and the Exif and GPS sub-IFDs, follow the
    entries, at offsets counted from the start of the TIFF: they are relocated.  The tags of
    `leave_out` and the maker's notes (whose inner offsets cannot be relocated) are left out, and
    so are the Interoperability sub-IFD and a thumbnail's IFD.  Pillow's exceptions on a
    malformed block pass through.
    """
    from PIL import TiffImagePlugin

    directory = TiffImagePlugin.ImageFileDirectory_v2(ifh=head)
    for tag, value in exif.items():
        if tag in _SUB_IFDS:
            value = {key: item for key, item in exif.get_ifd(tag).items() if key not in (_MAKER_NOTE, 40965)}
            if not value:
                continue
        elif tag in leave_out:
            continue
        directory[tag] = value
    laid_out = directory.tobytes(at)
    return laid_out + b"\x00" * (len(laid_out) % 2), len(directory)


def _tiff_exif(image) -> bytes | None:
    """The EXIF of a TIFF opened by Pillow as a block (little-endian, no prefix): the tags of its
    first IFD but `TIFF_LAYOUT_TAGS` and its ImageDescription (what wrote it says of its layout,
    stale for a warped copy), with its Exif and GPS sub-IFDs; None if it has none."""
    head = b"II*\x00" + struct.pack("<I", 8)
    try:
        laid_out, count = laid_out_exif(image.getexif(), TIFF_LAYOUT_TAGS | {_IMAGE_DESCRIPTION}, head, 8)
    except Exception:  # Pillow raises many kinds on damaged tags: the EXIF is left behind
        return None
    return head + laid_out if count else None


def _exif(block: bytes, notes: list[str]) -> tuple[bytes | None, int]:
    """The EXIF block without its prefix and with orientation 1, and the orientation it had."""
    block = block.removeprefix(EXIF_PREFIX)
    try:
        orientation, position = exif_orientation(block)
    except ValueError as error:
        notes.append(f"its EXIF block is malformed ({error}); dropped, orientation 1 assumed")
        return None, 1
    orientation = _checked_orientation(orientation, notes)
    if position is not None:
        order = "<" if block[:2] == b"II" else ">"
        block = block[:position] + struct.pack(order + "H", 1) + block[position + 2 :]
    return block, orientation


def _checked_orientation(value, notes: list[str]) -> int:
    """`value` if it is an EXIF orientation 1-8; 1 with a note otherwise (None: absent, 1)."""
    if value is None:
        return 1
    if isinstance(value, int) and 1 <= value <= 8:
        return value
    notes.append(f"its EXIF orientation {value!r} is not one of 1-8; ignored")
    return 1


def exif_orientation(block: bytes) -> tuple[int | None, int | None]:
    """The orientation in an EXIF block (a TIFF structure) and the byte offset of its value.

    Returns
    -------
    orientation, position : int or None
        None, None when the first IFD has no orientation tag.

    Raises
    ------
    ValueError
        The block is not a TIFF structure or its first IFD runs past its end.
    """
    if block[:4] not in (b"II*\x00", b"MM\x00*"):
        raise ValueError("no TIFF header")
    order = "<" if block[:2] == b"II" else ">"
    (offset,) = struct.unpack(order + "I", block[4:8])
    if offset + 2 > len(block):
        raise ValueError("its first IFD is beyond the block's end")
    (count,) = struct.unpack(order + "H", block[offset : offset + 2])
    if offset + 2 + 12 * count > len(block):
        raise ValueError("its first IFD runs past the block's end")
    for index in range(count):
        start = offset + 2 + 12 * index
        tag, kind, number = struct.unpack(order + "HHI", block[start : start + 8])
        if tag == ORIENTATION_TAG:
            if kind != 3 or number != 1:  # one SHORT
                raise ValueError("its orientation is not one SHORT")
            (value,) = struct.unpack(order + "H", block[start + 8 : start + 10])
            return value, start + 8
    return None, None


def oriented(pixels: np.ndarray, orientation: int) -> np.ndarray:
    """`pixels` as stored in a file turned into the displayed frame of EXIF `orientation`.

    Parameters
    ----------
    pixels : ndarray of shape (H, W, ...)
        Row 0 at the top as stored.
    orientation : int
        1 (as stored), 2 (mirrored left-right), 3 (turned 180 degrees), 4 (mirrored top-bottom),
        5 (transposed), 6 (turned 90 degrees clockwise), 7 (transversed), 8 (turned 90 degrees
        counterclockwise).

    Returns
    -------
    ndarray of shape (H, W, ...) or (W, H, ...)
        C-contiguous; `pixels` itself for orientation 1.
    """
    if orientation == 1:
        return pixels
    turned = {
        2: lambda p: p[:, ::-1],
        3: lambda p: p[::-1, ::-1],
        4: lambda p: p[::-1],
        5: lambda p: p.swapaxes(0, 1),
        6: lambda p: p.swapaxes(0, 1)[:, ::-1],
        7: lambda p: p.swapaxes(0, 1)[::-1, ::-1],
        8: lambda p: p.swapaxes(0, 1)[::-1],
    }[orientation](pixels)
    return np.ascontiguousarray(turned)
