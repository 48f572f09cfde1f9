"""`ViewMode`: what a view of the canvas is made of (`app.viewer.view_modes`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass


@dataclass(frozen=True)
class ViewMode:
    """One view of the canvas.

    Attributes
    ----------
    name : str
        In session files and the ``content`` command.
    label : str
        The panel's radio button.
    help : str
        The help panel's line for its key.
    drawn : str
        The renderer's ``content``: ``"image"``, ``"heat"``, ``"field"`` or ``"distortion"``.
    gradients : bool
        Needs grad G at the vertices (the precompute asks for them).
    field : callable or None
        ``field(state, basis, renderer, current)``: upload the per-vertex field to the
        renderer unless ``current`` (the signature of what it holds) says it is there;
        returns the new signature.  None for the image.
    legend : callable or None
        ``legend(state, draw, left, top, span)``: its colour bar, drawn with imgui.
    legend_height : float
        Window pixels of the colour bar's window.
    """

    name: str
    label: str
    help: str
    drawn: str
    gradients: bool = False
    field: Callable | None = None
    legend: Callable | None = None
    legend_height: float = 96.0
