"""The image-to-framebuffer transform shared by the renderer, the framing of outputs and the viewer.

Pure geometry (no GL): `app.warp.framing`, the viewer's state and editing import it
without importing moderngl.  Coordinates are image pixels, x to the right, y down,
origin at the image's top-left corner.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class View:
    """Image-to-framebuffer transform: image point (x, y) -> pixel (ox + s x, oy + s y).

    Parameters
    ----------
    scale : float
        s, framebuffer pixels per image pixel.
    offset : tuple of float
        (ox, oy) in framebuffer pixels from the top-left corner.
    """

    scale: float = 1.0
    offset: tuple[float, float] = (0.0, 0.0)

    @classmethod
    def fit(
        cls, box: tuple[float, float, float, float], target_size: tuple[int, int], margin: float = 0.0
    ) -> View:
        """The view that shows all of ``box`` as large as possible, centred.

        Parameters
        ----------
        box : tuple of float
            (x0, y0, x1, y1), the region to show, image pixels.
        target_size : tuple of int
            (width, height) of the framebuffer.
        margin : float
            Framebuffer pixels to keep free on every side.
        """
        x0, y0, x1, y1 = box
        scale = min((target_size[0] - 2 * margin) / (x1 - x0), (target_size[1] - 2 * margin) / (y1 - y0))
        return cls(
            scale,
            (0.5 * (target_size[0] - scale * (x0 + x1)), 0.5 * (target_size[1] - scale * (y0 + y1))),
        )
