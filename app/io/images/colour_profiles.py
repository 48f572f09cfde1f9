"""An output carries an ICC profile only if it describes its pixels, which are RGB.

A profile's header names the colour space of the pixels it describes (bytes 16-19: ``RGB ``,
``CMYK``, ``GRAY``...).  The pipeline's pixels are always RGB(A): a CMYK photograph with a CMYK
profile is converted to sRGB through that profile by littleCMS (Pillow's ImageCms) and written
with an sRGB profile; a profile of any other space than RGB is dropped with a note, since its
pixels were made RGB without it.  A profile that says it is longer than it is was cut short:
no reader can use it, so it is dropped with a note too.
"""

from __future__ import annotations

import io
import struct
from functools import cache

import numpy as np

#: Where the header of an ICC profile keeps the signature ``acsp`` and its colour space.
_SIGNATURE, _SPACE = slice(36, 40), slice(16, 20)
#: Bytes of an ICC profile's header.
HEADER_BYTES = 128


def profile_space(profile: bytes) -> str | None:
    """The colour space an ICC profile's header names (``"RGB"``, ``"CMYK"``, ``"GRAY"``...), or None
    for bytes without the header of a profile."""
    if len(profile) < HEADER_BYTES or profile[_SIGNATURE] != b"acsp":
        return None
    return profile[_SPACE].decode("latin-1").strip()


def cut_short(profile: bytes) -> int | None:
    """The length the header of `profile` declares, if it is more than the bytes there are; else None."""
    if len(profile) < 4:
        return None
    (declared,) = struct.unpack(">I", profile[:4])
    return declared if declared > len(profile) else None


@cache
def srgb_profile() -> bytes:
    """littleCMS's sRGB profile, as the bytes written with pixels converted to sRGB."""
    from PIL import ImageCms

    return ImageCms.ImageCmsProfile(ImageCms.createProfile("sRGB")).tobytes()


def cmyk_as_srgb(data: bytes, profile: bytes) -> np.ndarray:
    """The pixels of the CMYK image file `data` converted to sRGB through its ICC `profile` by
    littleCMS (perceptual intent): RGBA uint8 (H, W, 4), opaque, as stored (orientation not applied).

    Raises
    ------
    ValueError
        littleCMS cannot read the profile, or Pillow the pixels.
    """
    from PIL import Image, ImageCms

    try:
        source = ImageCms.ImageCmsProfile(io.BytesIO(profile))
        with Image.open(io.BytesIO(data)) as image:
            converted = ImageCms.profileToProfile(
                image, source, ImageCms.createProfile("sRGB"), outputMode="RGB"
            )
    except (OSError, ValueError, ImageCms.PyCMSError) as error:
        raise ValueError(f"littleCMS cannot convert through it ({error})") from None
    return np.asarray(converted.convert("RGBA")).copy()


def matched_profile(data: bytes, mode: str | None, metadata, notes: list[str], convert: bool = True):
    """The pixels and metadata of an image file whose profile must describe RGB pixels.

    Parameters
    ----------
    data : bytes
        The whole file.
    mode : str or None
        Pillow's pixel mode of the file (`app.io.images.metadata.FileInfo.mode`).
    metadata : app.io.images.ImageMetadata
        What its headers carry.
    notes : list of str
        What is converted or dropped is added here, one line each.
    convert : bool
        Convert a CMYK file's pixels through its CMYK profile (False: only say which profile the
        converted pixels would carry).

    Returns
    -------
    pixels : ndarray of shape (H, W, 4), uint8, or None
        The CMYK pixels converted to sRGB, as stored; None where the decoder's pixels stand.
    metadata : app.io.images.ImageMetadata
        With the profile that goes with the pixels: the file's (RGB), sRGB's (converted CMYK) or none.
    """
    from dataclasses import replace

    profile = metadata.icc_profile
    space = None if profile is None else profile_space(profile)
    if space is None or space == "RGB":  # none, or not a profile (noted when read): as it is
        return None, metadata
    if space == "CMYK" and mode == "CMYK":
        try:
            pixels = cmyk_as_srgb(data, profile) if convert else _readable(profile)
        except ValueError as error:
            notes.append(f"its CMYK ICC profile cannot be used: {error}; dropped, CMYK made RGB without it")
            return None, replace(metadata, icc_profile=None)
        if convert:
            notes.append("its CMYK pixels are converted to sRGB through its ICC profile, written with sRGB's")
        return pixels, replace(metadata, icc_profile=srgb_profile())
    notes.append(f"its ICC profile describes {space} pixels, not the RGB ones written; dropped")
    return None, replace(metadata, icc_profile=None)


def _readable(profile: bytes) -> None:
    """ValueError if littleCMS cannot read `profile`."""
    from PIL import ImageCms

    try:
        source = ImageCms.ImageCmsProfile(io.BytesIO(profile))
        ImageCms.buildTransform(source, ImageCms.createProfile("sRGB"), "CMYK", "RGB")
    except (OSError, ValueError, ImageCms.PyCMSError) as error:
        raise ValueError(f"littleCMS cannot read it ({error})") from None
