"""Keeping the viewer's basis functions those of the document shown: which precompute the live
snapshot wants (`app.viewer.precompute.make_request`), its progress and errors, and the result
put in `AppState.compute` when it arrives (or at once, when the worker remembers it)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from app.viewer import editing
from app.viewer.precompute import Precompute, make_request
from app.viewer.state import AppState, BasisResult
from app.viewer.view_modes import BY_NAME as VIEW_MODE


class BasisUpdates:
    """The requests of basis functions for the live snapshot, and their results.

    Parameters
    ----------
    precompute : Precompute
        The worker process.
    max_edge : float, optional
        The mesh edge length of the command line (``--max-edge``), for every cage.
    vertices : int, optional
        About how many vertices a cage's mesh has otherwise (``--vertices``;
        default `app.viewer.editing.TARGET_VERTICES`).
    announce : callable
        Called with one line per result (the window tests read them).
    """

    def __init__(
        self,
        precompute: Precompute,
        max_edge: float | None,
        vertices: int | None,
        announce: Callable[[str], None],
    ):
        self.precompute = precompute
        self.forced_edge, self.vertices = max_edge, vertices
        self.announce = announce
        self.edges: dict[bytes, float] = {}  # a cage's bytes -> its mesh edge length
        self.wanted: str | None = None  # the key of the basis the live snapshot needs
        self.failed: set[str] = set()

    def remember_edge(self, cage: np.ndarray, max_edge: float) -> None:
        """Mesh `cage` (n, 2) with edges of at most `max_edge` (a session's)."""
        if self.vertices is None:
            self.edges[cage.tobytes()] = max_edge

    def max_edge(self, cage: np.ndarray) -> float:
        """The mesh edge length of `cage` (n, 2): the command line's, a session's, or from its area."""
        if self.forced_edge is not None:
            return self.forced_edge
        key = cage.tobytes()
        if key not in self.edges:
            self.edges[key] = editing.default_max_edge(cage, self.vertices or editing.TARGET_VERTICES)
        return self.edges[key]

    def ready(self, state: AppState) -> bool:
        """Whether the basis drawn is the one the live snapshot wants."""
        return state.compute.basis is not None and state.compute.basis.key == self.wanted

    def update(self, state: AppState) -> None:
        """Read the worker's messages, then ask for the live snapshot's basis if it is not there."""
        compute = state.compute
        for message in self.precompute.poll():
            kind, key = message[0], message[1]
            if kind == "progress" and key == self.precompute.pending:
                compute.progress, compute.progress_label = message[2], message[3]
            elif kind == "done":
                compute.progress = None if self.precompute.pending is None else compute.progress
                if key == self.wanted:
                    self.apply(state, message[2])
            elif kind == "error":
                if self.precompute.pending is None:
                    compute.progress = None
                self.failed.add(key)
                if key == self.wanted:
                    compute.basis_error = message[2]
                    state.say(message[2], error=True)
        live = state.document.live
        if state.selection.drag is not None or state.selection.drawing is not None or live.n < 3:
            return
        gradients = VIEW_MODE[state.display.view_mode].gradients
        wanted = make_request(live, self.max_edge(live.cage), gradients=gradients)
        self.wanted = wanted.key
        if compute.basis is not None and compute.basis.key == wanted.key:
            return
        remembered = self.precompute.remembered(wanted.key)
        if remembered is not None:
            self.apply(state, remembered, cached=True)
        elif wanted.key in self.failed:
            return
        elif self.precompute.pending != wanted.key:
            self.precompute.submit(wanted)
            compute.progress, compute.progress_label = 0.0, "starting"
            compute.basis_error = ""

    def apply(self, state: AppState, result: BasisResult, cached: bool = False) -> None:
        """Draw `result` from now on."""
        compute = state.compute
        compute.basis = result
        compute.basis_error = ""
        if not cached:
            compute.progress = None
        vertices = len(result.mesh.vertices)
        preview = 0 if result.preview is None else len(result.preview.vertices)
        self.announce(f"basis key={result.key} vertices={vertices} kernel={result.kernel} preview={preview}")
