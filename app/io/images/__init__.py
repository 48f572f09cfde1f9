"""Photographs in and out: pixels at their depth, EXIF orientation, ICC profile and EXIF kept.

`reading` (RGBA at the file's depth, `Photo`), `metadata` (ICC, EXIF, orientation) and
`writing` (files by extension: PNG, TIFF, JPEG, WebP).  `app.io.files.read_photo`,
`read_image` and `write_image` are the entry points the commands use.
"""

from app.io.images.metadata import ImageMetadata, oriented, read_metadata
from app.io.images.reading import Photo, rgba_pixels, straight_rgba_tiff
from app.io.images.writing import (
    DEFAULT_QUALITY,
    OUTPUT_FORMATS,
    TransparentOutputError,
    encode_image,
    has_alpha,
    output_format,
)

__all__ = [
    "DEFAULT_QUALITY",
    "OUTPUT_FORMATS",
    "ImageMetadata",
    "Photo",
    "TransparentOutputError",
    "encode_image",
    "has_alpha",
    "oriented",
    "output_format",
    "read_metadata",
    "rgba_pixels",
    "straight_rgba_tiff",
]
