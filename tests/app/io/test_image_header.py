"""Tests of app.io.image_header: sizes from file headers, checked against OpenCV's decoding."""

import struct

import cv2
import numpy as np
import pytest
from support.png_files import blank_png, declared_png

from app.io.image_header import ImageHeader, image_header

WIDTH, HEIGHT = 37, 23


def picture(channels, dtype=np.uint8):
    rng = np.random.default_rng(channels)
    shape = (HEIGHT, WIDTH) if channels == 1 else (HEIGHT, WIDTH, channels)
    return rng.integers(0, np.iinfo(dtype).max, shape, dtype=dtype, endpoint=True)


def encoded(extension, image, *params):
    ok, data = cv2.imencode(extension, image, list(params))
    assert ok
    return data.tobytes()


CASES = [
    (".png", 3, np.uint8, (), "PNG", 3, 8),
    (".png", 4, np.uint8, (), "PNG", 4, 8),
    (".png", 1, np.uint16, (), "PNG", 1, 16),
    (".jpg", 3, np.uint8, (), "JPEG", 3, 8),
    (".jpg", 1, np.uint8, (cv2.IMWRITE_JPEG_PROGRESSIVE, 1), "JPEG", 1, 8),
    (".bmp", 3, np.uint8, (), "BMP", 3, 8),
    (".bmp", 4, np.uint8, (), "BMP", 4, 8),
    (".webp", 3, np.uint8, (cv2.IMWRITE_WEBP_QUALITY, 80), "WebP", 3, 8),
    (".webp", 4, np.uint8, (cv2.IMWRITE_WEBP_QUALITY, 101), "WebP", 4, 8),
    (".tiff", 3, np.uint8, (), "TIFF", 3, 16),
    (".tiff", 1, np.uint16, (), "TIFF", 1, 16),
    (".ppm", 3, np.uint8, (), "PNM", 3, 8),
    (".gif", 3, np.uint8, (), "GIF", 3, 8),
]


@pytest.mark.parametrize(("extension", "channels", "dtype", "params", "name", "stored", "depth"), CASES)
def test_header_matches_the_decoded_image(extension, channels, dtype, params, name, stored, depth):
    data = encoded(extension, picture(channels, dtype), *params)
    header = image_header(data)
    assert header == ImageHeader(name, WIDTH, HEIGHT, stored, depth)
    decoded = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    assert decoded.shape[:2] == (header.height, header.width)


def test_jpeg_start_of_frame_after_large_segments():
    data = encoded(".jpg", picture(3))
    # Application segments (EXIF, ICC profiles) of 64 KiB each before the frame header.
    filler = b"".join(b"\xff\xe2" + struct.pack(">H", 65535) + bytes(65533) for _ in range(3))
    assert image_header(data[:2] + filler + data[2:]).width == WIDTH


def test_a_declared_size_is_read_without_the_data():
    data = declared_png(30000, 30000)
    assert len(data) == 65
    assert image_header(data) == ImageHeader("PNG", 30000, 30000, 3, 8)
    assert image_header(data).pixels == 900_000_000


def test_a_real_blank_png_is_read_like_any_other():
    data = blank_png(WIDTH, HEIGHT, channels=4)
    assert image_header(data) == ImageHeader("PNG", WIDTH, HEIGHT, 4, 8)
    assert cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED).shape == (HEIGHT, WIDTH, 4)


def test_portable_arbitrary_map_with_comments():
    data = b"P7\n# a comment\nWIDTH 37\nHEIGHT 23\nDEPTH 4\nMAXVAL 65535\nTUPLTYPE RGB_ALPHA\nENDHDR\n"
    assert image_header(data + bytes(8)) == ImageHeader("PNM", 37, 23, 4, 16)


@pytest.mark.parametrize(
    "data",
    [
        b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n",  # a format not read here
        b"\x89PNG\r\n\x1a\n\x00\x00",  # cut short
        b"\xff\xd8\xff\xe0\x00",  # JPEG without a frame header
        b"BM this is text",  # not a BMP info header
        b"P6\n# only a comment",
        b"",
    ],
)
def test_unknown_or_short_headers_give_none(data):
    assert image_header(data) is None
