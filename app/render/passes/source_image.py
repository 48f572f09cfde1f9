"""The source image on the GPU: a mipmapped texture with premultiplied alpha and its sampler, of
the whole image or of the part of it a drawing samples.

An opaque 8-bit image is an RGBA8 texture, an opaque 16-bit one an RGBA16 texture (normalised
16-bit integers, filtered and mipmapped like RGBA8): the texture holds the image itself, drawn and
read back at its depth.  A translucent image is premultiplied at a finer depth (`drawn_dtype`: 16
bits for an 8-bit image, 32-bit floats for a 16-bit one), so that its straight colour comes back
from a drawing within a unit at every alpha, even the lowest (an 8-bit colour premultiplied at 8
bits keeps two levels at alpha 1).
"""

from __future__ import annotations

import moderngl
import numpy as np

#: Rows of the image uploaded at a time.
UPLOAD_ROWS = 512
#: GL's own bound on mipmap levels (``GL_TEXTURE_MAX_LEVEL``'s default): every level.
_LEVELS_MAX = 1000


def checked_image(ctx: moderngl.Context, image) -> np.ndarray:
    """`image` as an (H, W, 4) uint8 array, or ValueError saying why the GL driver cannot take it.

    Parameters
    ----------
    ctx : moderngl.Context
        The context whose largest texture side limits the image.
    image : array_like of shape (H, W, 4), uint8 or uint16
    """
    image = np.asarray(image)
    if image.dtype not in (np.uint8, np.uint16) or image.ndim != 3 or image.shape[2] != 4:
        raise ValueError(
            f"image must be an (H, W, 4) uint8 or uint16 array, got {image.dtype} of shape {image.shape}"
        )
    height, width = image.shape[:2]
    limit = ctx.info["GL_MAX_TEXTURE_SIZE"]
    if max(width, height) > limit:
        raise ValueError(f"image is {width}x{height} pixels; this GL driver takes at most {limit} per side")
    return image


class SourceImage:
    """The texture of the source image, or of the part of it a drawing samples, through texture unit 0.

    Parameters
    ----------
    ctx : moderngl.Context
    image : ndarray of shape (H, W, 4), uint8 or uint16
        RGBA with straight alpha, row 0 at the top, as `checked_image` returns it.
    box : tuple of int, optional
        (left, top, right, bottom), image pixels: the texture holds these pixels alone, and a
        drawing through it must sample no others (`app.render.compositing.sampled_box`); the whole
        image if None.

    Attributes
    ----------
    size : tuple of int
        (W, H) of the image.
    box : tuple of int
        (left, top, right, bottom) of the image held by the texture.
    dtype : numpy.dtype
        uint8 or uint16: the image's samples.
    opaque : bool
        Whether every alpha of `box` is its type's maximum: the texture then holds the image itself.
    drawn_dtype : numpy.dtype
        The texture's samples, and those a drawing must be read back in to keep the image's
        precision: `dtype` for an opaque image, else uint16 (8-bit image) or float32 (16-bit).
    """

    def __init__(self, ctx: moderngl.Context, image: np.ndarray, box: tuple[int, ...] | None = None):
        height, width = image.shape[:2]
        self.size = (width, height)
        self.box = (0, 0, width, height) if box is None else tuple(int(side) for side in box)
        left, top, right, bottom = self.box
        held = image[top:bottom, left:right]
        self.dtype = image.dtype
        # Row 0 of the data is texture row v = 0, so v = y / H needs no flip.  Uploaded (and
        # premultiplied) a strip at a time: a 100-megapixel image is 0.4 GB, and a whole copy of
        # it on the way to the driver would be as much again.
        maximum = np.iinfo(image.dtype).max
        self.opaque = all(
            held[row : row + UPLOAD_ROWS, :, 3].min() == maximum for row in range(0, len(held), UPLOAD_ROWS)
        )
        self.drawn_dtype = np.dtype(image.dtype if self.opaque else _PREMULTIPLIED[np.dtype(image.dtype)])
        self._texture = ctx.texture((right - left, bottom - top), 4, dtype=texture_dtype(self.drawn_dtype))
        for row in range(0, len(held), UPLOAD_ROWS):
            rows = held[row : row + UPLOAD_ROWS]
            premultiplied = rows if self.opaque else _premultiply(rows)
            viewport = (0, row, right - left, len(rows))
            self._texture.write(np.ascontiguousarray(premultiplied), viewport=viewport)
        # The mipmaps are built at the first drawing that samples them (`bind`): by then the caller
        # may have let go of `image`, and the driver's temporaries of that step (~0.8 of the image)
        # do not come on top of the image's array (issue 36: 100 megapixels within 1.5 GiB); a
        # drawing that shrinks nothing never builds them (issue 48).
        self._levels = 0  # the mipmaps built, past the image itself
        # Clamp to a transparent border: parts of the domain beyond the image
        # stay empty instead of smearing the edge pixels, and fade smoothly.
        self._samplers = {
            mipmaps: ctx.sampler(
                repeat_x=False,
                repeat_y=False,
                filter=(moderngl.LINEAR_MIPMAP_LINEAR if mipmaps else moderngl.LINEAR, moderngl.LINEAR),
                anisotropy=_anisotropy(ctx) if mipmaps else 1.0,
                border_color=(0.0, 0.0, 0.0, 0.0),
                texture=self._texture,
            )
            for mipmaps in (True, False)
        }
        self._bound: moderngl.Sampler | None = None

    def bind(self, program: moderngl.Program, mipmaps: bool = True) -> None:
        """Sample the image in `program`'s ``u_image`` (and tell it the part the texture holds:
        ``image.frag.glsl``'s ``u_boxed``, ``u_image_size``, ``u_region``); `unbind` after drawing.

        Parameters
        ----------
        program : moderngl.Program
        mipmaps : bool
            Filter trilinearly through the mipmaps (every level built at the first such drawing,
            unless `build_mipmaps` built those it needs); False: bilinear filtering of the image
            itself, the same pixels wherever no triangle shrinks the picture
            (`app.render.compositing.texel_footprints` at most 1).
        """
        if mipmaps and not self._levels:
            self.build_mipmaps()
        self._bound = self._samplers[mipmaps]
        self._bound.use(location=0)
        program["u_image"].value = 0
        left, top, right, bottom = self.box
        program["u_boxed"].value = self.box != (0, 0, *self.size)
        program["u_image_size"].value = self.size
        program["u_region"].value = (left, top, right - left, bottom - top)

    def build_mipmaps(self, levels: int | None = None) -> None:
        """Build the mipmaps now, if they are not yet (a drawing that samples them would): the first
        `levels` past the image itself (GL samples no coarser one), or every one if None."""
        wanted = _LEVELS_MAX if levels is None else max(1, int(levels))
        if self._levels < wanted:
            self._texture.build_mipmaps(0, wanted)
            self._levels = wanted

    def unbind(self) -> None:
        """Unbind the sampler: a bound sampler object overrides any texture's own filtering on its
        unit, and other code drawing into the same context (imgui) must be unaffected."""
        if self._bound is not None:
            self._bound.clear(location=0)
            self._bound = None

    def release(self) -> None:
        for sampler in self._samplers.values():
            sampler.release()
        self._texture.release()


def _anisotropy(ctx: moderngl.Context) -> float:
    """Anisotropic filtering level: 16 where the driver does it right, else 1.

    Mesa's llvmpipe (measured on 22.3) blurs even unscaled texture lookups once
    anisotropy exceeds 1 (a one-pixel checkerboard drawn 1:1 is off by up to 201
    of 255), so there plain trilinear filtering is the better result.
    """
    if "llvmpipe" in ctx.info["GL_RENDERER"]:
        return 1.0
    return min(16.0, ctx.max_anisotropy)


def texture_dtype(dtype: np.dtype) -> str:
    """moderngl's texture and renderbuffer type for samples of `dtype`: normalised 8 or 16 bits, or
    32-bit floats."""
    return {np.dtype(np.uint8): "f1", np.dtype(np.uint16): "nu2", np.dtype(np.float32): "f4"}[np.dtype(dtype)]


#: The samples a translucent image is premultiplied in, by the image's: a unit of the image's
#: colour over the least alpha (1 / 255, 1 / 65535) still shows in them.
_PREMULTIPLIED = {np.dtype(np.uint8): np.dtype(np.uint16), np.dtype(np.uint16): np.dtype(np.float32)}


def _premultiply(image: np.ndarray) -> np.ndarray:
    """RGBA uint8 or uint16 (H, W, 4), straight alpha -> premultiplied RGBA (H, W, 4): uint16 of
    round(c a 65535 / 255^2) for uint8, float32 of c a / 65535^2 (and a / 65535) for uint16."""
    maximum = np.iinfo(image.dtype).max
    if image.dtype == np.uint8:
        wide = image.astype(np.uint32)
        result = np.empty(image.shape, np.uint16)
        # c a 257 / 255 rounded: c a / 255^2 in units of 1 / 65535
        result[..., :3] = (wide[..., :3] * wide[..., 3:] * 257 + 127) // 255
        result[..., 3] = wide[..., 3] * 257
        return result
    wide = image.astype(np.float64) / maximum
    wide[..., :3] *= wide[..., 3:]
    return wide.astype(np.float32)
