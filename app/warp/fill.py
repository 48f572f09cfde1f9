"""Filling the subject's original position under the warp (GIMP's cage tool: "fill the original position").

With ``outside = original`` the untouched picture is drawn behind the warp, so a cage
moved away leaves the subject showing where it was.  A fill replaces the inside of the
source cage in that backdrop (not in the texture the warp samples):

- ``none``: the original stays (the default);
- ``transparent``: clear pixels;
- a colour ``#RRGGBB`` or ``#RRGGBBAA``;
- ``inpaint``: the surroundings continued inwards (OpenCV's ``cv2.inpaint``, Telea's method).

`warp --fill`, `animate` and the viewer all call `set_fill` on their renderer, so they
draw the same pixels.  Images are (H, W, 4) uint8 or uint16 RGBA with straight alpha, row 0 at
the top; cages (n, 2) control points in image pixels, x right, y down.
"""

from __future__ import annotations

import re

import numpy as np

from app.io.files import InputError

#: The fills besides a colour.
FILLS = ("none", "transparent", "inpaint")
#: Pixels the filled region reaches beyond the source curve: the old subject's antialiased edge.
MARGIN = 2
#: Radius (pixels) of the neighbourhood `cv2.inpaint` takes each filled pixel from.
INPAINT_RADIUS = 5
#: Most masked pixels inpainted at full resolution (`_inpaint`).
INPAINT_PIXELS = 60_000
#: Curve samples per span for the mask's polygon.
SAMPLES_PER_SPAN = 32
_COLOUR = re.compile(r"#([0-9a-fA-F]{6}|[0-9a-fA-F]{8})")


def checked_fill(value: str, where: str = "--fill") -> str:
    """`value` as a fill: one of `FILLS`, or a colour as ``#rrggbb``/``#rrggbbaa`` (lower case).

    Raises `InputError` naming `where` otherwise.
    """
    if isinstance(value, str) and value in FILLS:
        return value
    if isinstance(value, str) and _COLOUR.fullmatch(value):
        return value.lower()
    raise InputError(f"{where}: must be {', '.join(FILLS)} or a colour such as #ffffff, got {value!r}")


def chosen_fill(option: str | None, saved: str, outside: str) -> str:
    """The fill of a command: ``--fill`` (`option`, None when not given) over the session's (`saved`).

    Raises `InputError` for a bad `option`, or a fill other than ``none`` asked for without
    ``--outside original`` (there is no backdrop to fill then).
    """
    if option is None:
        return saved
    fill = checked_fill(option)
    if outside != "original" and fill != "none":
        raise InputError("--fill fills the original position behind the warp: give --outside original too")
    return fill


def colour_of(fill: str) -> tuple[int, int, int, int]:
    """The RGBA (0-255) of a colour fill ``#rrggbb`` (opaque) or ``#rrggbbaa``."""
    digits = checked_fill(fill)[1:]
    values = [int(digits[i : i + 2], 16) for i in range(0, len(digits), 2)]
    return tuple(values + [255] * (4 - len(values)))


def cage_mask(cage: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """The pixels of an image of `shape` (H, W) whose centres lie inside the closed curve of `cage`
    or within `MARGIN` pixels of it: bool ndarray of shape (H, W)."""
    import cv2

    from core import ClosedBSpline

    curve = ClosedBSpline(cage)
    points = curve(np.arange(SAMPLES_PER_SPAN * curve.n) / SAMPLES_PER_SPAN)
    # cv2 puts integer coordinates at pixel centres (x + 0.5 here); 4 bits of subpixel precision.
    fixed = np.round((points - 0.5) * 16).astype(np.int32)
    mask = np.zeros(shape, np.uint8)
    cv2.fillPoly(mask, [fixed], 255, lineType=cv2.LINE_8, shift=4)
    size = 2 * MARGIN + 1
    grow = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
    return cv2.dilate(mask, grow) > 0


def filled_image(image: np.ndarray, cage: np.ndarray, fill: str) -> np.ndarray | None:
    """`image` with the inside of `cage`'s curve filled, ndarray (H, W, 4) of its type; None for ``none``.

    Parameters
    ----------
    image : ndarray of shape (H, W, 4), uint8 or uint16
    cage : ndarray of shape (n, 2)
        Source control points (a valid cage: `core.ClosedBSpline` raises ValueError otherwise).
    fill : str
        One of `FILLS` or a colour (`checked_fill`).
    """
    fill = checked_fill(fill)
    if fill == "none":
        return None
    mask = cage_mask(cage, image.shape[:2])
    filled = image.copy()
    if fill == "transparent":
        filled[mask] = 0
    elif fill == "inpaint":
        _inpaint(filled, mask)
    else:  # a colour's 0-255 values at the image's depth (65535 = 255 * 257)
        filled[mask] = np.asarray(colour_of(fill), np.uint32) * (257 if image.dtype == np.uint16 else 1)
    return filled


def _inpaint(image: np.ndarray, mask: np.ndarray) -> None:
    """Fill `image`'s pixels under `mask` in place from their surroundings, within the mask's
    bounding box grown by what `cv2.inpaint` reads (the rest of the image does not change it).

    Telea's method costs ~5 us a masked pixel: a region of more than `INPAINT_PIXELS` is
    inpainted at a lower resolution holding that many and scaled back up (the fill is smooth
    at any scale), so a subject of millions of pixels takes about a second, not minutes.
    """
    import cv2

    rows, columns = np.nonzero(mask)
    if not rows.size:
        return
    reach = INPAINT_RADIUS + 2
    top, bottom = max(rows.min() - reach, 0), min(rows.max() + reach + 1, image.shape[0])
    left, right = max(columns.min() - reach, 0), min(columns.max() + reach + 1, image.shape[1])
    window = image[top:bottom, left:right]
    inside = mask[top:bottom, left:right]
    factor = min(1.0, float(np.sqrt(INPAINT_PIXELS / rows.size)))
    if factor < 1.0:
        size = (max(round(factor * window.shape[1]), 1), max(round(factor * window.shape[0]), 1))
        small = cv2.resize(window, size, interpolation=cv2.INTER_AREA)
        small_inside = cv2.resize(inside.astype(np.uint8), size, interpolation=cv2.INTER_AREA) > 0
        _inpaint_pixels(small, small_inside)
        filled = cv2.resize(small, (window.shape[1], window.shape[0]), interpolation=cv2.INTER_LINEAR)
        window[inside] = filled[inside]
    else:
        _inpaint_pixels(window, inside)


def _inpaint_pixels(image: np.ndarray, mask: np.ndarray) -> None:
    """`cv2.inpaint` (Telea) of the colour and the alpha of an (H, W, 4) uint8 or uint16 image, in
    place: the colour of an 8-bit image as one 3-channel picture, a 16-bit image's channels one by
    one (`cv2.inpaint` takes 16 bits in one channel only)."""
    import cv2

    inside = mask.astype(np.uint8)
    groups = ([0, 1, 2], [3]) if image.dtype == np.uint8 else ([0], [1], [2], [3])
    for channels in groups:
        part = image[..., channels] if len(channels) > 1 else image[..., channels[0]]
        filled = cv2.inpaint(np.ascontiguousarray(part), inside, INPAINT_RADIUS, cv2.INPAINT_TELEA)
        image[..., channels] = filled.reshape(*filled.shape[:2], len(channels))


def set_fill(renderer, image: np.ndarray, cage: np.ndarray, fill: str, outside: str) -> None:
    """Give `renderer` (an `app.render.renderer.WarpRenderer` holding `image`) the backdrop of `outside` and
    `fill`: the image filled inside `cage` for ``outside == "original"`` and a fill other than
    ``none``; the plain image otherwise."""
    filled = filled_image(image, cage, fill) if outside == "original" else None
    renderer.set_backdrop_image(filled)
