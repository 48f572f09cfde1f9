"""The untouched picture under an offscreen warp, copied rather than drawn (``--outside original``).

Drawn at one output pixel per image pixel and a whole-pixel offset, the backdrop of
`app.render.renderer.WarpRenderer.render` is the picture itself: its pixels are copied, bit for bit
and with their straight alpha (`backdrop_rows`), GL draws only the warp, alone and only within the
box the deformed mesh covers (`drawn_box`), and that drawing is laid over the copy where it covers
anything: an opaque picture's drawing over it (`warp_over`: its alpha is the warp's coverage), a
translucent picture's drawing in place of it where the warp covers the pixel wholly, blended by the
coverage drawn apart (`warp_laid`) where it covers part: its alpha is the picture's own.
`texel_footprints` tell whether a triangle shrinks the picture, that is
whether a drawing samples the texture's mipmaps at all.

Pixels are RGBA of shape (h, w, 4), uint8 or uint16, row 0 at the top; a View maps image point
(x, y) to output pixel (ox + s x, oy + s y).
"""

from __future__ import annotations

import cv2
import numpy as np

#: Rows of the image read at a time by `backdrop_rows`.
READ_ROWS = 128
#: Output pixels added around the deformed mesh's bounding box: a multisampled pixel is drawn
#: where any of its samples falls in a triangle.
BOX_MARGIN = 1
#: Largest of `texel_footprints` drawn from a texture of the image's part around the mesh alone
#: (`sampled_box`); past it, of the whole image.
BOXED_FOOTPRINT = 8.0
#: Image pixels added around the undeformed mesh's box in `sampled_box`, and the step of its sides.
SAMPLED_MARGIN = 64


def exact_offset(view) -> tuple[int, int] | None:
    """(ox, oy) of a `View` of scale 1 and whole-pixel offsets, whose output pixels are image pixels;
    None for any other view."""
    if view.scale != 1 or not all(float(offset).is_integer() for offset in view.offset):
        return None
    return int(view.offset[0]), int(view.offset[1])


def drawn_box(
    positions: np.ndarray, offset: tuple[int, int], size: tuple[int, int]
) -> tuple[int, ...] | None:
    """(left, top, right, bottom), output pixels, holding every pixel the mesh deformed to
    `positions` (V, 2) can touch through the view of `offset`, within an output of `size`
    (width, height); None if it touches none."""
    low = np.floor(positions.min(axis=0)) + offset - BOX_MARGIN
    high = np.ceil(positions.max(axis=0)) + offset + BOX_MARGIN
    left, top = max(int(low[0]), 0), max(int(low[1]), 0)
    right, bottom = min(int(high[0]), size[0]), min(int(high[1]), size[1])
    if left >= right or top >= bottom:
        return None
    return left, top, right, bottom


def clear_pixel(background: tuple[float, float, float, float], dtype) -> np.ndarray:
    """The straight RGBA of `dtype` (4,) that a GL clear to `background` (straight, in [0, 1]) reads
    back as: premultiplied and rounded at the depth of `dtype`, then made straight again."""
    maximum = np.iinfo(dtype).max
    red, green, blue, alpha = background
    drawn = np.round(np.array([red * alpha, green * alpha, blue * alpha, alpha]) * maximum)
    return straight(drawn[None, None].astype(dtype))[0, 0]


def straight(pixels: np.ndarray) -> np.ndarray:
    """Premultiplied RGBA uint8 or uint16 (h, w, 4) -> straight alpha, in place; only partly covered
    pixels change (opaque ones are exactly what was drawn)."""
    maximum = np.iinfo(pixels.dtype).max
    alpha = pixels[..., 3]
    partial = (alpha > 0) & (alpha < maximum)
    if partial.any():
        # float64 for 16 bits: float32's 24 bits would round c * 65535 / a off by a unit.
        wide = np.float32 if maximum == 255 else np.float64
        a = alpha[partial].astype(wide)[:, None]
        result = np.clip(pixels[partial, :3] * (wide(maximum) / a) + 0.5, 0, maximum)
        pixels[partial, :3] = result.astype(pixels.dtype)
    return pixels


def backdrop_rows(image, offset: tuple[int, int], rows: np.ndarray, top: int, clear: np.ndarray) -> None:
    """Fill `rows` (r, width, 4), output rows from `top` on, with the image put at `offset` over the
    straight colour `clear` (4,): the image's pixels themselves wherever `clear` is transparent or the
    image opaque, blended over `clear` elsewhere.

    Parameters
    ----------
    image : tuple
        (width, height) of the image and a function of (top, bottom, left, right, out=None) giving
        those of its rows and columns, straight RGBA (h, w, 4) of the type of `rows` (into `out`,
        a C-contiguous array, if given).
    """
    (width, height), read = image
    x0, y0 = offset
    first, last = max(top - y0, 0), min(top + len(rows) - y0, height)
    left, right = max(-x0, 0), min(rows.shape[1] - x0, width)
    if clear[3] != 0 or (last - first, right - left) != rows.shape[:2]:  # shows somewhere
        rows[...] = clear
    if first >= last or left >= right:
        return
    whole = clear[3] == 0 and rows.flags.c_contiguous and (left + x0, right + x0) == (0, rows.shape[1])
    for start in range(first, last, READ_ROWS):  # a few MB at a time, not a whole strip more
        end = min(start + READ_ROWS, last)
        into = rows[start + y0 - top : end + y0 - top, left + x0 : right + x0]
        if whole:  # whole rows: read straight into them
            read(start, end, left, right, into)
            continue
        source = read(start, end, left, right)
        if clear[3] == 0:
            into[...] = source
            continue
        cover = source.copy()
        cover[..., :3] = _premultiplied(source)
        into[...] = warp_over(into, cover)


def warp_over(base: np.ndarray, drawn: np.ndarray) -> np.ndarray:
    """`drawn` laid over `base`, in place in `base`, which is returned: untouched where `drawn` is
    clear, `drawn` itself where it is opaque, blended where it partly covers, rounded once.

    Parameters
    ----------
    base : ndarray of shape (h, w, 4), uint8 or uint16
        Straight alpha.
    drawn : ndarray of shape (h, w, 4), float32 in [0, 1], uint16 or the type of `base`
        Premultiplied alpha, as GL reads it back.
    """
    full = 1.0 if drawn.dtype == np.float32 else np.iinfo(drawn.dtype).max
    alpha = drawn[..., 3]
    opaque = alpha >= full
    if opaque.all():  # a tile inside the warp: its pixels as drawn
        base[...] = narrowed(drawn, base.dtype)
        return base
    if opaque.any():
        _copy_pixels(base, narrowed(drawn, base.dtype), opaque)
    partial = (alpha > 0) & ~opaque
    if partial.any():
        maximum = np.iinfo(base.dtype).max
        over = drawn[partial].astype(np.float64) / full
        under = base[partial].astype(np.float64) / maximum
        kept = 1 - over[:, 3:]
        result_alpha = over[:, 3:] + under[:, 3:] * kept
        colour = (over[:, :3] + under[:, :3] * under[:, 3:] * kept) / result_alpha
        base[partial] = _rounded(np.concatenate([colour, result_alpha], axis=1), base.dtype)
    return base


def warp_laid(base: np.ndarray, drawn: np.ndarray, coverage: np.ndarray, clear: np.ndarray) -> np.ndarray:
    """A translucent picture's warp laid on `base` (the picture over `clear`), in place, which is
    returned: premultiplied, drawn + (1 - coverage) base + (coverage - drawn's alpha) clear, the
    warp laid on the picture and both over `clear`, rounded once; untouched where `coverage` is 0,
    `drawn` alone (made straight) where it is whole and `clear` transparent, the colour of `base`
    where the result is transparent.

    Parameters
    ----------
    base : ndarray of shape (h, w, 4), uint8 or uint16
        Straight alpha.
    drawn : ndarray of shape (h, w, 4), uint16 or float32 in [0, 1]
        The warp, premultiplied alpha, as GL reads it back.
    coverage : ndarray of shape (h, w), the type of `drawn`
        How much of each pixel the warp covers (``image.frag.glsl``'s ``u_coverage``).
    clear : ndarray of shape (4,), the type of `base`
        The straight colour under the picture (`clear_pixel`).
    """
    full = 1.0 if drawn.dtype == np.float32 else np.iinfo(drawn.dtype).max
    touched = coverage > 0
    if not touched.any():
        return base
    maximum = np.iinfo(base.dtype).max
    over = drawn[touched].astype(np.float64) / full
    kept = 1 - np.minimum(coverage[touched].astype(np.float64) / full, 1.0)[:, None]
    under = base[touched].astype(np.float64) / maximum
    behind = clear.astype(np.float64) / maximum
    shows = np.maximum(1 - kept - over[:, 3:], 0) * behind[3]  # where the warp covers, its gaps
    alpha = over[:, 3:] + kept * under[:, 3:] + shows
    colour = over[:, :3] + kept * under[:, :3] * under[:, 3:] + shows * behind[:3]
    # A pixel left wholly transparent keeps the colour under it (unseen, but a straight picture's
    # own: an identity warp gives back even the colour of its transparent pixels).
    colour = np.divide(colour, alpha, out=under[:, :3].copy(), where=alpha > 0)
    base[touched] = _rounded(np.concatenate([np.minimum(colour, 1.0), alpha], axis=1), base.dtype)
    return base


def _copy_pixels(base: np.ndarray, pixels: np.ndarray, where: np.ndarray) -> None:
    """`pixels` (h, w, 4) copied into `base` (h, w, 4, the same integer type) `where` (h, w) is True: each
    pixel moved as one integer where both hold their samples side by side (30 times faster than
    a mask broadcast over the samples)."""
    whole = {1: np.uint32, 2: np.uint64}[base.dtype.itemsize]
    if all(a.strides[-1] == a.itemsize and a.strides[-2] == 4 * a.itemsize for a in (base, pixels)):
        np.copyto(base.view(whole)[..., 0], pixels.view(whole)[..., 0], where=where)
    else:
        np.copyto(base, pixels, where=where[..., None])


def narrowed(drawn: np.ndarray, dtype) -> np.ndarray:
    """Samples `drawn` (h, w, 4) of uint8, uint16 or float32 in [0, 1] as the nearest samples of
    the integer `dtype` (`drawn` itself if of that type): 16 bits to 8 by round(x / 257) in integers
    (x / 257 is never half-way between two integers), in float32 otherwise."""
    if drawn.dtype == dtype:
        return drawn
    if drawn.dtype == np.uint16 and dtype == np.uint8:
        return cv2.convertScaleAbs(drawn, alpha=1 / 257)
    full = 1.0 if drawn.dtype == np.float32 else np.iinfo(drawn.dtype).max
    return _rounded(drawn / np.float32(full), dtype)


def _rounded(values: np.ndarray, dtype) -> np.ndarray:
    """Floats in [0, 1] as the nearest samples of the integer `dtype`."""
    maximum = np.iinfo(dtype).max
    return np.clip(values * maximum + 0.5, 0, maximum).astype(dtype)


def mipmap_levels(footprint: float) -> int:
    """The mipmap levels past the image itself that a drawing samples where one output pixel steps
    over at most `footprint` image pixels: GL's level log2 of it and the next (trilinear filtering),
    and one more for its drivers' approximations of the footprint."""
    return int(np.floor(np.log2(max(footprint, 1.0)))) + 2


def sampled_box(vertices: np.ndarray, size: tuple[int, int], footprint: float) -> tuple[int, ...] | None:
    """(left, top, right, bottom), image pixels: what a drawing of a mesh of the undeformed
    `vertices` (V, 2), image pixels, samples of an image of `size` (width, height) where one output
    pixel steps over at most `footprint` image pixels; None (the whole image) past
    `BOXED_FOOTPRINT`.

    The box of the vertices, `SAMPLED_MARGIN` more on each side, its sides on multiples of it
    (or the image's): a pixel centre is up to 0.71 output pixels past a triangle's edge (0.71
    `footprint` image pixels), and bilinear filtering of mipmap level k (`mipmap_levels`, at most 5
    here) reaches 1.5 2^k pixels past the point filtered (48); the mipmaps of a texture of the box
    keep the whole image's grid up to level 6.
    """
    if not footprint <= BOXED_FOOTPRINT:
        return None
    low = np.floor((vertices.min(axis=0) - SAMPLED_MARGIN) / SAMPLED_MARGIN) * SAMPLED_MARGIN
    high = np.ceil((vertices.max(axis=0) + SAMPLED_MARGIN) / SAMPLED_MARGIN) * SAMPLED_MARGIN
    left, top = max(int(low[0]), 0), max(int(low[1]), 0)
    right, bottom = min(int(high[0]), size[0]), min(int(high[1]), size[1])
    if left >= right or top >= bottom:
        return None
    return left, top, right, bottom


def texel_footprints(
    vertices: np.ndarray, positions: np.ndarray, triangles: np.ndarray, scale: float
) -> np.ndarray:
    """The most image pixels that one output pixel steps over inside each triangle (GL's rho, whose
    log2 is the mipmap level sampled; at most 1 where the triangle does not shrink the picture).

    Parameters
    ----------
    vertices, positions : ndarray of shape (V, 2)
        The mesh's vertices, undeformed and deformed, image pixels.
    triangles : ndarray of shape (T, 3)
    scale : float
        Output pixels per image pixel.

    Returns
    -------
    ndarray of shape (T,)
        The longer column of J^-1, J the triangle's affine map from image to output pixels;
        infinite where a triangle collapses.
    """
    corners = vertices[triangles].astype(np.float64)
    moved = positions[triangles].astype(np.float64) * scale
    source = np.stack([corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]], axis=2)
    drawn = np.stack([moved[:, 1] - moved[:, 0], moved[:, 2] - moved[:, 0]], axis=2)
    if not len(triangles):
        return np.zeros(0)
    determinant = drawn[:, 0, 0] * drawn[:, 1, 1] - drawn[:, 0, 1] * drawn[:, 1, 0]
    collapsed = np.abs(determinant) <= 1e-12 * np.abs(drawn).max(axis=(1, 2)) ** 2
    determinant[collapsed] = 1.0
    inverse = np.empty_like(drawn)
    inverse[:, 0, 0], inverse[:, 1, 1] = drawn[:, 1, 1], drawn[:, 0, 0]
    inverse[:, 0, 1], inverse[:, 1, 0] = -drawn[:, 0, 1], -drawn[:, 1, 0]
    inverse /= determinant[:, None, None]
    steps = source @ inverse  # columns: image pixels per output pixel along x and along y
    footprints = np.sqrt((steps**2).sum(axis=1)).max(axis=1)
    footprints[collapsed] = np.inf
    return footprints


def _premultiplied(image: np.ndarray) -> np.ndarray:
    """The colour of straight RGBA `image` (h, w, 4) premultiplied by its alpha, rounded: (h, w, 3)."""
    maximum = np.iinfo(image.dtype).max
    wide = np.uint32 if image.dtype == np.uint8 else np.uint64
    colour = image[..., :3].astype(wide) * image[..., 3:].astype(wide)
    return ((colour + maximum // 2) // maximum).astype(image.dtype)
