"""The viewer's views of the canvas, one module each: what the mesh shows besides the image.

A view is a `ViewMode`: its name (the session's ``viewer.content`` and the ``content``
command), its label in the panel, what the renderer draws (`WarpRenderer.draw`'s
``content``), whether it needs the basis gradients, the per-vertex field it shows and
its legend.  `MODES` lists them in the panel's order (Shift+1, Shift+2, ...); a new view
is a module here and one entry of `MODES`.
"""

from __future__ import annotations

from app.viewer.view_modes import basis, distortion, height, image
from app.viewer.view_modes.mode import ViewMode

MODES: tuple[ViewMode, ...] = (image.MODE, basis.MODE, height.MODE, distortion.MODE)
BY_NAME = {mode.name: mode for mode in MODES}
#: The views' names, in the panel's order.
VIEW_MODE_NAMES = tuple(BY_NAME)
