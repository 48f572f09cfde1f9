"""What part of the plane an exported warp shows, and at what size (``--canvas``, ``--scale``, ``--size``).

``canvas="source"`` frames the source image's rectangle; ``canvas="grow"`` widens
it to hold the whole target curve too, so that a target that leaves the image is
not clipped.  Both `python -m app warp` and the viewer's export use `output_frame`,
so they write the same pixels.
"""

from __future__ import annotations

import numpy as np

from app.io.image_header import MAX_IMAGE_PIXELS
from app.render.viewport import View
from app.warp.keyframes import Keyframe, interpolate
from core import basis_weights

#: Most pixels of an output (`output_frame`, `app.render.renderer.WarpRenderer.render`), as of an input image.
MAX_OUTPUT_PIXELS = MAX_IMAGE_PIXELS

CANVASES = ("source", "grow")
OUTSIDES = ("transparent", "original")
#: Curve samples per span for the target's bounding box (sub-pixel for spans under ~1,000 px).
SAMPLES_PER_SPAN = 64


def output_region(image_size: tuple[int, int], target: np.ndarray, canvas: str) -> tuple[float, ...]:
    """(x0, y0, x1, y1) in image pixels: the image, or (``grow``) the image and the target curve.

    Parameters
    ----------
    image_size : tuple of int
        (width, height) of the source image.
    target : ndarray of shape (n, 2)
        Target control points; the curve is sampled (it may cross itself) and its
        bounding box rounded outwards to whole pixels.
    canvas : {"source", "grow"}
    """
    if canvas not in CANVASES:
        raise ValueError(f"canvas must be one of {', '.join(CANVASES)}, got {canvas!r}")
    width, height = image_size
    x0, y0, x1, y1 = 0.0, 0.0, float(width), float(height)
    if canvas == "grow":
        target = np.asarray(target, dtype=np.float64)
        t = np.arange(len(target) * SAMPLES_PER_SPAN) / SAMPLES_PER_SPAN
        index, weights = basis_weights(t, len(target))
        curve = np.einsum("mk,mkd->md", weights, target[index])
        low, high = np.floor(curve.min(axis=0)), np.ceil(curve.max(axis=0))
        x0, y0 = min(x0, float(low[0])), min(y0, float(low[1]))
        x1, y1 = max(x1, float(high[0])), max(y1, float(high[1]))
    return x0, y0, x1, y1


def output_frame(
    region: tuple[float, float, float, float],
    scale: float | None = None,
    size: tuple[int, int] | None = None,
) -> tuple[tuple[int, int], View]:
    """Output size (width, height) and the image-to-output `View` that shows `region`.

    At most one of `scale` (output pixels per image pixel) and `size` (fit the
    region into it); with neither, one output pixel per image pixel.

    Raises
    ------
    ValueError
        An output of more than `MAX_OUTPUT_PIXELS` pixels.
    """
    x0, y0, x1, y1 = region
    if size is not None:
        width, height = int(size[0]), int(size[1])
    else:
        scale = 1.0 if scale is None else float(scale)
        width, height = max(1, round((x1 - x0) * scale)), max(1, round((y1 - y0) * scale))
    if width * height > MAX_OUTPUT_PIXELS:
        shown = (
            f"{width}x{height} pixels ({width * height / 1e6:.0f} megapixels)"
            if max(width, height) <= MAX_OUTPUT_PIXELS
            else f"over {MAX_OUTPUT_PIXELS:,} pixels a side"
        )
        raise ValueError(
            f"the output would be {shown}; at most {MAX_OUTPUT_PIXELS / 1e6:.0f} megapixels can be written: "
            "give a smaller --size or --scale"
        )
    if size is not None:
        return (width, height), View.fit(region, size)
    return (width, height), View(scale, (-scale * x0, -scale * y0))


def frame_region(
    image_size: tuple[int, int], keyframes: tuple[Keyframe, ...], interpolation: str, times, canvas: str
) -> tuple[float, float, float, float]:
    """(x0, y0, x1, y1), image pixels: `app.warp.framing.output_region` of every frame's target, joined.

    One frame for the whole animation: with ``canvas="grow"`` it holds the
    target curve at every time in `times` (interpolation may overshoot keyframes).
    """
    regions = np.array(
        [
            output_region(image_size, interpolate(keyframes, float(t), interpolation), canvas)
            for t in (times if canvas == "grow" else times[:1])
        ]
    )
    return (*regions[:, :2].min(axis=0), *regions[:, 2:].max(axis=0))
