"""PNG files made in memory: a header that declares a size with no pixels, a blank picture."""

from __future__ import annotations

import struct
import zlib


def _png_chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def declared_png(width: int, height: int) -> bytes:
    """A PNG header declaring width x height RGB pixels, and no pixel data (65 bytes)."""
    return (
        b"\x89PNG\r\n\x1a\n"
        + _png_chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
        + _png_chunk(b"IDAT", zlib.compress(b""))
        + _png_chunk(b"IEND", b"")
    )


def blank_png(width: int, height: int, channels: int = 1) -> bytes:
    """A real, valid, all-zero PNG of width x height pixels: big in pixels, small in bytes."""
    colour = {1: 0, 3: 2, 4: 6}[channels]
    return (
        b"\x89PNG\r\n\x1a\n"
        + _png_chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, colour, 0, 0, 0))
        + _png_chunk(b"IDAT", _zeros_zlib(height * (1 + width * channels)))  # filter byte 0 and 0s a row
        + _png_chunk(b"IEND", b"")
    )


def _zeros_zlib(count: int, block: int = 1 << 24) -> bytes:
    """A zlib stream of `count` zero bytes, deflating only one `block` of them: a full flush ends
    the blocks so far on a byte boundary with nothing referred back past it, so the deflated
    block repeats; Adler-32 of n zero bytes is (n mod 65521) << 16 | 1."""
    whole, rest = divmod(count, block)
    repeated = zlib.compressobj(1, zlib.DEFLATED, -15)
    piece = repeated.compress(bytes(block)) + repeated.flush(zlib.Z_FULL_FLUSH) if whole else b""
    last = zlib.compressobj(1, zlib.DEFLATED, -15)
    tail = last.compress(bytes(rest)) + last.flush()
    checksum = struct.pack(">I", (count % 65521) << 16 | 1)
    return b"\x78\x01" + piece * whole + tail + checksum
