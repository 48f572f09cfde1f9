"""Image size from the file header, before any pixel is decoded.

A 74-byte PNG can declare 30000 x 30000 pixels; OpenCV allocates the whole image
(2.7 GB) before it finds out that the data is missing.  `image_header` reads
width, height, channels and bits per sample from the headers of PNG, JPEG, BMP,
GIF, WebP, TIFF and PNM/PAM files, so that `app.io.files.read_image` can refuse
what it cannot process without allocating it.  Other formats return None (OpenCV's
own pixel limit, set to the same `MAX_IMAGE_PIXELS` by `app/__init__.py`, then applies).
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass

#: Largest image (width x height) processed: 2^27 pixels, 512 MiB as RGBA (twice that while decoding).
MAX_IMAGE_PIXELS = 1 << 27


@dataclass(frozen=True)
class ImageHeader:
    """What a file header declares.

    Attributes
    ----------
    format : str
        ``"PNG"``, ``"JPEG"``, ...
    width, height : int
        Pixels.
    channels : int
        Samples per pixel as stored (a palette counts as 3).
    depth : int
        Bits per sample.
    """

    format: str
    width: int
    height: int
    channels: int
    depth: int

    @property
    def pixels(self) -> int:
        """width x height."""
        return self.width * self.height


class _Truncated(Exception):
    """The header ends early: the decoder will say what is wrong."""


def image_header(data: bytes) -> ImageHeader | None:
    """The header of the image file `data`, or None if the format is not one read here or the
    header is cut short or malformed (then the decoder reports the problem)."""
    for signature, reader in _READERS:
        if data.startswith(signature):
            try:
                return reader(data)
            except (_Truncated, struct.error, ValueError, IndexError):
                return None
    return None


def _png(data: bytes) -> ImageHeader:
    if data[12:16] != b"IHDR":
        raise _Truncated
    width, height, depth, colour = struct.unpack(">IIBB", data[16:26])
    channels = {0: 1, 2: 3, 3: 3, 4: 2, 6: 4}.get(colour, 4)
    return ImageHeader("PNG", width, height, channels, depth)


# Start-of-frame markers of every JPEG coding process (not DHT C4, JPG C8, DAC CC).
_START_OF_FRAME = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}


def _jpeg(data: bytes) -> ImageHeader:
    offset = 2
    while offset + 4 <= len(data):
        if data[offset] != 0xFF:
            raise _Truncated
        marker = data[offset + 1]
        if marker == 0xFF:  # fill byte
            offset += 1
            continue
        if marker == 0x01 or 0xD0 <= marker <= 0xD9:  # markers without a length
            offset += 2
            continue
        (length,) = struct.unpack(">H", data[offset + 2 : offset + 4])
        if marker in _START_OF_FRAME:
            depth, height, width, channels = struct.unpack(">BHHB", data[offset + 4 : offset + 10])
            return ImageHeader("JPEG", width, height, channels, depth)
        offset += 2 + length
    raise _Truncated


def _bmp(data: bytes) -> ImageHeader:
    (size,) = struct.unpack("<I", data[14:18])
    if size not in (12, 16, 40, 52, 56, 64, 108, 124):  # not a BMP info header: let the decoder say
        raise _Truncated
    if size == 12:  # OS/2 BITMAPCOREHEADER
        width, height, _, bits = struct.unpack("<HHHH", data[18:26])
    else:
        width, height, _, bits = struct.unpack("<iiHH", data[18:30])
    return ImageHeader("BMP", abs(width), abs(height), 4 if bits == 32 else 3, 8)


def _gif(data: bytes) -> ImageHeader:
    width, height = struct.unpack("<HH", data[6:10])
    return ImageHeader("GIF", width, height, 3, 8)


def _webp(data: bytes) -> ImageHeader:
    if data[8:12] != b"WEBP":
        raise _Truncated
    chunk = data[12:16]
    if chunk == b"VP8 ":
        width, height = struct.unpack("<HH", data[26:30])
        return ImageHeader("WebP", width & 0x3FFF, height & 0x3FFF, 3, 8)
    if chunk == b"VP8L":
        (bits,) = struct.unpack("<I", data[21:25])
        return ImageHeader("WebP", (bits & 0x3FFF) + 1, ((bits >> 14) & 0x3FFF) + 1, 4, 8)
    if chunk == b"VP8X":
        width = int.from_bytes(data[24:27], "little") + 1
        height = int.from_bytes(data[27:30], "little") + 1
        return ImageHeader("WebP", width, height, 4, 8)
    raise _Truncated


_TIFF_TYPES = {3: ("H", 2), 4: ("I", 4)}  # SHORT, LONG


def _tiff(data: bytes) -> ImageHeader:
    order = "<" if data[:2] == b"II" else ">"
    (offset,) = struct.unpack(order + "I", data[4:8])
    (count,) = struct.unpack(order + "H", data[offset : offset + 2])
    values = {}
    for index in range(count):
        start = offset + 2 + 12 * index
        tag, kind, _ = struct.unpack(order + "HHI", data[start : start + 8])
        if kind in _TIFF_TYPES:
            code, size = _TIFF_TYPES[kind]
            (values[tag],) = struct.unpack(order + code, data[start + 8 : start + 8 + size])
    if 256 not in values or 257 not in values:
        raise _Truncated
    # BitsPerSample holds one value per sample; with several it is an offset, so assume 16.
    channels = values.get(277, 1)
    depth = values.get(258, 8) if channels <= 2 else 16
    return ImageHeader("TIFF", values[256], values[257], channels, depth)


_PNM_CHANNELS = {b"P1": 1, b"P2": 1, b"P3": 3, b"P4": 1, b"P5": 1, b"P6": 3}


def _pnm(data: bytes) -> ImageHeader:
    head = re.sub(rb"#[^\n]*", b" ", data[:4096])
    if head[:2] == b"P7":
        fields = dict(re.findall(rb"(WIDTH|HEIGHT|DEPTH|MAXVAL)\s+(\d+)", head))
        width, height = int(fields[b"WIDTH"]), int(fields[b"HEIGHT"])
        channels, maximum = int(fields.get(b"DEPTH", 1)), int(fields.get(b"MAXVAL", 255))
    else:
        bitmap = head[:2] in (b"P1", b"P4")  # no maximum value: one bit per sample
        numbers = [int(value) for value in head[2:].split()[: 2 if bitmap else 3]]
        width, height = numbers[0], numbers[1]
        channels, maximum = _PNM_CHANNELS[head[:2]], 1 if bitmap else numbers[2]
    return ImageHeader("PNM", width, height, channels, 16 if maximum > 255 else 8)


_READERS = (
    (b"\x89PNG\r\n\x1a\n", _png),
    (b"\xff\xd8", _jpeg),
    (b"BM", _bmp),
    (b"GIF87a", _gif),
    (b"GIF89a", _gif),
    (b"RIFF", _webp),
    (b"II*\x00", _tiff),
    (b"MM\x00*", _tiff),
    *((signature, _pnm) for signature in (b"P1", b"P2", b"P3", b"P4", b"P5", b"P6", b"P7")),
)
