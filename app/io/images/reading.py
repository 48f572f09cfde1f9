"""Decoded pixels as the pipeline takes them: RGBA, row 0 at the top, at the file's depth.

OpenCV decodes grey, grey with alpha, colour and colour with alpha, 8 or 16 bits per
sample, in blue-green-red order; `rgba_pixels` turns each into straight-alpha RGBA of
the same depth (alpha at its type's maximum where the file has none).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from app.io.images.metadata import ImageMetadata

_CONVERSIONS = {1: cv2.COLOR_GRAY2RGBA, 3: cv2.COLOR_BGR2RGBA, 4: cv2.COLOR_BGRA2RGBA}


@dataclass(frozen=True)
class Photo:
    """An image read from a file, in its displayed frame.

    Attributes
    ----------
    pixels : ndarray of shape (H, W, 4), uint8 or uint16
        RGBA, straight alpha, row 0 at the top of the displayed (EXIF-oriented) picture.
    metadata : ImageMetadata
        The ICC profile and EXIF block (orientation reset to 1) to write with a warped copy.
    notes : tuple of str
        What was dropped or ignored while reading, one line each.
    """

    pixels: np.ndarray
    metadata: ImageMetadata = field(default_factory=ImageMetadata)
    notes: tuple[str, ...] = ()

    def metadata_only(self) -> Photo:
        """This photograph without its pixels (an empty array of the same depth), to keep its
        metadata while the pixels are freed."""
        return Photo(np.empty((0, 0, 4), self.pixels.dtype), self.metadata, self.notes)

    @property
    def depth(self) -> int:
        """Bits per sample: 8 or 16."""
        return 8 * self.pixels.dtype.itemsize


def rgba_pixels(decoded: np.ndarray) -> np.ndarray:
    """RGBA of OpenCV's decoding (grey, BGR or BGRA; uint8 or uint16), at the same depth.

    Parameters
    ----------
    decoded : ndarray of shape (H, W) or (H, W, C), C in 1, 3, 4

    Returns
    -------
    ndarray of shape (H, W, 4), same dtype

    Raises
    ------
    ValueError
        Another sample type (32-bit, floating point) or number of channels.
    """
    if decoded.dtype not in (np.uint8, np.uint16):
        raise ValueError(f"unsupported pixel type {decoded.dtype}; use 8- or 16-bit images")
    channels = 1 if decoded.ndim == 2 else decoded.shape[2]
    if channels not in _CONVERSIONS:
        raise ValueError(f"unsupported image with {channels} channels")
    return cv2.cvtColor(decoded, _CONVERSIONS[channels])


def straight_rgba_tiff(data: bytes) -> np.ndarray:
    """The first page of an 8-bit RGBA TIFF file, decoded by Pillow: ndarray (H, W, 4) uint8, straight alpha.

    Raises
    ------
    ValueError
        The file cannot be decoded (cut short, damaged).
    """
    import io

    from PIL import Image

    try:
        with Image.open(io.BytesIO(data)) as image:
            return np.asarray(image.convert("RGBA")).copy()
    except (OSError, ValueError, SyntaxError) as error:
        raise ValueError(f"cannot decode the image ({error})") from None
