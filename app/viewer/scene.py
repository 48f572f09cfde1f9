"""Keeps the `WarpRenderer` in step with `AppState`, doing per frame only what changed.

- a new image: upload the texture;
- new basis functions: upload the mesh (the only time vertex arrays are built);
- a changed target of a dense mesh (one with a `PreviewMesh`) while a handle moves or
  keyframes play, with the image view: only the preview mesh's ~20k positions
  (its G @ P'), drawn instead of the dense mesh, which is also drawn so while the
  view pans or zooms; the dense mesh's exact positions when the motion stops;
- a changed target otherwise: during a drag of one point, the rank-one update
  x' += G[:, i] (P'_i(new) - P'_i(old)) of float32 positions, O(V) whatever n is,
  and one in-place buffer write (rows of x' and G kept in the renderer's vertex
  order); during keyframe playback G @ P' in float32 without BLAS
  (`combined_columns`); otherwise (undo, release, script, playback stopped) the
  exact product G @ P' in float64, the one `python -m app warp` uses, and the
  count of folded triangles;
- the field of the basis-function, height or distortion view when it changes (the
  distortion view's after every change of the target: `app.viewer.distortion_view`);
- the overlay of curves, control polygons and handles (a few kilobytes) every frame.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from app.render.renderer import WarpRenderer
from app.render.viewport import View
from app.viewer import pin_tool
from app.viewer.controller import band_corners
from app.viewer.drawing import clicked_points
from app.viewer.editing import curve_points, to_image
from app.viewer.fold_free import HARMONIC_KERNEL, current_check
from app.viewer.fold_free_frames import FoldFreeFrames, PreviewBasis
from app.viewer.state import TARGET_DRAGS, WARPING_MODES, AppState
from app.viewer.view_modes import BY_NAME as VIEW_MODES
from app.warp.fill import set_fill
from app.warp.framing import output_region
from core import deform

#: Straight RGB of the overlays: the source curve green, the target blue (the paper's Fig. 11).
SOURCE_COLOUR = (0.16, 0.80, 0.28)
TARGET_COLOUR = (0.22, 0.48, 1.00)
SELECTED_COLOUR = (1.00, 0.86, 0.20)
HOVER_COLOUR = (1.00, 1.00, 1.00)
#: The frame of what an export holds, when the target leaves the image (`export_frame`).
EXPORT_FRAME_COLOUR = (0.85, 0.85, 0.85)
BACKGROUND = (0.13, 0.13, 0.14)


def overlay_arrays(state: AppState) -> tuple[np.ndarray, np.ndarray]:
    """Line segments (S, 2, 7) and handles (K, 7) for `WarpRenderer.set_overlay`.

    The curve of the mode being edited is drawn wider and on top, with large
    handles; the other one thinner and fainter.  The selected handle is yellow, the
    hovered one white.  While a new cage is drawn only it is shown, its handles at the
    points clicked; while it is still open they are joined in order, a line runs on to the
    cursor, and the closed curve is a faint preview.
    """
    live = state.document.live
    active = "source" if state.selection.edit_mode == "cage" else "target"
    drawing = state.selection.drawing is not None and not state.selection.drawing.closed
    segments, points = [], []
    for kind in sorted(("source", "target"), key=lambda k: k == active):
        control = live.cage if kind == "source" else live.target
        colour = SOURCE_COLOUR if kind == "source" else TARGET_COLOUR
        is_active = kind == active
        if state.selection.drawing is not None and not is_active:
            continue  # the target of a cage being drawn is that cage: its control points would only confuse
        alpha = 1.0 if is_active else 0.55
        if len(control) >= 3:
            curve_alpha = 0.35 * alpha if drawing else alpha
            segments.append(
                _closed_segments(curve_points(control), colour, curve_alpha, 2.5 if is_active else 1.5)
            )
        if state.selection.drawing is not None and is_active:
            control = clicked_points(
                state
            )  # the clicks: on the curve, or its control points (drawing.STYLES)
        if len(control) >= 2:
            polygon = control if len(control) >= 3 else control[:2]
            if drawing:  # the points in the order placed, not yet closed
                segments.append(_closed_segments(polygon, colour, alpha, 1.5)[:-1])
            else:
                segments.append(_closed_segments(polygon, colour, 0.45 * alpha, 1.0))
        if drawing and is_active and len(control):
            cursor = to_image(state.display.viewport, [state.screen.cursor])
            segments.append(_closed_segments(np.vstack([control[-1:], cursor]), colour, 0.6, 1.0)[:1])
        size = 11.0 if is_active else 7.0
        if kind == "target" and state.selection.drawing is None:
            points.append(pin_tool.fixed_marks(state))  # under the handles, showing around them
        handles = np.zeros((len(control), 7))
        handles[:, :2] = control
        handles[:, 2:5] = colour
        handles[:, 5] = alpha
        handles[:, 6] = size
        if is_active:
            for index, fill, grow in (
                *((i, SELECTED_COLOUR, 0.0) for i in state.selection.group),
                (state.selection.hovered, HOVER_COLOUR, 4.0),
                (state.selection.selected, SELECTED_COLOUR, 2.0),
            ):
                if index is not None and index < len(control):
                    handles[index, 2:5] = fill
                    handles[index, 6] = size + grow
        points.append(handles)
    frame = export_frame(state)
    if frame is not None:
        segments.append(_closed_segments(frame, EXPORT_FRAME_COLOUR, 0.8, 1.0))
    band = band_corners(state)
    if band is not None:
        (x0, y0), (x1, y1) = band
        corners = to_image(state.display.viewport, [[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
        segments.append(_closed_segments(corners, SELECTED_COLOUR, 0.9, 1.0))
    points.append(fold_marks(state))
    pin_segments, pin_marks = pin_tool.overlay(state)
    segments.append(pin_segments)
    points.append(pin_marks)
    segments = np.concatenate(segments) if segments else np.zeros((0, 2, 7))
    return segments, np.concatenate(points)


def export_frame(state: AppState) -> np.ndarray | None:
    """Corners (4, 2), image pixels, of what an export holds (`app.warp.framing.output_region`), or None.

    Shown in deform mode when the target curve leaves the image: with ``canvas="source"``
    the export is clipped there, with ``"grow"`` it widens to this frame.
    """
    target = state.document.live.target
    if state.selection.edit_mode not in WARPING_MODES or len(target) < 3 or state.document.image is None:
        return None
    height, width = state.document.image.shape[:2]
    curve = curve_points(target)
    if curve.min() >= 0 and (curve <= (width, height)).all():
        return None
    x0, y0, x1, y1 = output_region((width, height), target, state.document.canvas)
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])


def _closed_segments(polyline: np.ndarray, colour, alpha: float, width: float) -> np.ndarray:
    ends = np.roll(polyline, -1, axis=0)
    segments = np.zeros((len(polyline), 2, 7))
    segments[:, 0, :2], segments[:, 1, :2] = polyline, ends
    segments[:, :, 2:5] = colour
    segments[:, :, 5] = alpha
    segments[:, :, 6] = width
    return segments


def combined_columns(
    columns: np.ndarray, target: np.ndarray, imaginary: np.ndarray | None = None
) -> np.ndarray:
    """G @ P' as float32 (V, 2), one column of G at a time, without BLAS.

    A BLAS product leaves OpenBLAS's worker threads spinning for a while after it
    returns; on a two-core machine they take the CPU from llvmpipe's rasteriser
    threads, and the frame drawn next (measured at 20k vertices) took 40-49 ms
    instead of 26 ms.

    Parameters
    ----------
    columns : ndarray of shape (V, n), float32, column-major
    target : ndarray of shape (n, 2)
    imaginary : ndarray of shape (V, n), float32, column-major, optional
        The imaginary part of complex coordinates: then G = columns + i imaginary acts on
        the target points as complex numbers (`core.deform`).
    """
    target = np.asarray(target, dtype=np.float32)
    result = np.zeros((2, columns.shape[0]), dtype=np.float32)
    for i in range(columns.shape[1]):
        _add_column(result, columns[:, i], None if imaginary is None else imaginary[:, i], target[i])
    return np.ascontiguousarray(result.T)


def _add_column(positions: np.ndarray, real: np.ndarray, imaginary: np.ndarray | None, delta) -> None:
    """positions (2, V) += column * delta (2,): (G_i) P'_i, complex G_i times P'_i = x + iy if `imaginary`."""
    positions[0] += real * delta[0]
    positions[1] += real * delta[1]
    if imaginary is not None:
        positions[0] -= imaginary * delta[1]
        positions[1] += imaginary * delta[0]


@dataclass(frozen=True)
class Columns:
    """Columns of G, float32, column-major, rows in the renderer's vertex order (so that a drag
    writes without a gather).

    Attributes
    ----------
    columns : ndarray of shape (V, n)
        G, or its real part.
    imaginary : ndarray of shape (V, n) or None
        The imaginary part of complex coordinates (Cauchy-Green).
    order : ndarray of shape (V,) or None
        The renderer's vertex order: row k is the mesh's vertex order[k].
    """

    columns: np.ndarray
    imaginary: np.ndarray | None = None
    order: np.ndarray | None = None


@dataclass
class Preview:
    """The preview mesh's G, rows in the renderer's preview vertex order, and the target its
    positions were last made for (fold-free or not)."""

    columns: Columns | None = None
    target: np.ndarray | None = None
    fold_free: bool = False  # its positions were the fold-free frames'
    frames: FoldFreeFrames = field(default_factory=FoldFreeFrames)  # drawn on it with fold-free on


@dataclass
class Layer:
    """The backdrop-and-mesh layer kept between frames: its framebuffer, the key of what it holds,
    and the key of what the last frame drew (a picture drawn twice in a row is kept)."""

    framebuffer: object = None  # moderngl.Framebuffer
    key: tuple | None = None
    drawn: tuple | None = None


def _fold_free_positions(state: AppState) -> np.ndarray | None:
    """The fold-free map at the mesh's vertices (V, 2) for the live target, when the document asks
    for it and the background check has made it for this very target (`current_check`)."""
    check = current_check(state)
    if check is None or not state.document.live.fold_free:
        return None
    return check.positions


#: The marks of the points where the injectivity proof fails (`WarpCheck.where`): red dots.
FOLD_MARK_COLOUR = (1.00, 0.25, 0.30)


def fold_marks(state: AppState) -> np.ndarray:
    """Handles (K, 7) at the points where the live warp's proof fails, none while it is proven or
    not yet checked."""
    check = current_check(state)
    if check is None or check.injective or state.selection.edit_mode not in WARPING_MODES:
        return np.zeros((0, 7))
    marks = np.zeros((len(check.marks), 7))
    marks[:, :2] = check.marks
    marks[:, 2:5] = FOLD_MARK_COLOUR
    marks[:, 5] = 0.9
    marks[:, 6] = 9.0
    return marks


def _mesh_pending(state: AppState, meshed: bool, warps: bool) -> bool:
    """Whether the view will show a warp once the basis being computed arrives (a cold start takes
    seconds): until then its frames draw the backdrop that view will show, at the same opacity, and
    no mesh, so that nothing drawn meanwhile vanishes when the warp comes.  Not when the basis
    cannot come (`Compute.basis_error`): then the whole image, as outside a warp."""
    return warps and not meshed and not state.compute.basis_error


class Scene:
    """The renderer's side of the state, updated once per frame by `sync`.

    Parameters
    ----------
    renderer : WarpRenderer
    """

    def __init__(self, renderer: WarpRenderer):
        self.renderer = renderer
        self._image = None
        self._fill_key: tuple | None = None  # what the renderer's backdrop was filled for
        self._basis = None
        # (the target drawn (n, 2), the fold-free positions (V, 2) drawn for it or None), None: none.
        self._drawn: tuple[np.ndarray, np.ndarray | None] | None = None
        self._positions: np.ndarray | None = None  # float32, in the renderer's vertex order
        self._dense: Columns | None = None  # G of the drawn mesh, in the renderer's vertex order
        self._exact = False
        self._field = None
        # The preview mesh's G, rows in the renderer's preview vertex order.
        self._preview = Preview()
        #: Whether the frame being drawn shows the preview mesh (`sync` decides).
        self.previewing = False
        # The backdrop-and-mesh layer (`draw`) and what it was drawn with.
        self._layer = Layer()
        #: CPU time of the last per-drag position update (ms), for the status line and tests.
        self.update_ms = 0.0
        # (the renderer's revision at which `_positions` were written, whether they may fold there:
        # None until asked).
        self._fold_check: tuple[int, bool | None] | None = None
        #: The positions drawn with "Fold-free" on (`app.viewer.fold_free_frames`).
        self.fold_free_frames = FoldFreeFrames()

    @property
    def layer_key(self) -> tuple | None:
        """What the backdrop-and-mesh layer's framebuffer holds (None: nothing kept)."""
        return self._layer.key

    @property
    def fold_free_drawn(self) -> bool:
        """Whether the mesh drawn has fold-free positions: the certified map's (`app.viewer.fold_free`)
        or the fold-free frames' (`app.viewer.fold_free_frames`)."""
        return self._drawn is not None and self._drawn[1] is not None and not self.previewing

    @property
    def has_mesh(self) -> bool:
        return self._basis is not None

    def mesh_matches(self, state: AppState) -> bool:
        """Whether the uploaded mesh belongs to the current source cage (so the warp is meaningful)."""
        basis = self._basis
        return basis is not None and np.array_equal(basis.cage, state.document.live.cage)

    def sync(self, state: AppState) -> None:
        """Upload what changed since the last frame."""
        renderer = self.renderer
        if state.document.image is not self._image:
            renderer.set_image(state.document.image)
            self._image = state.document.image
            self._fill_key = None  # a new image drops the filled backdrop
        self._update_fill(state)
        basis = state.compute.basis
        if basis is not None and basis is not self._basis:
            renderer.set_mesh(basis.mesh.vertices, basis.mesh.triangles)
            self._basis = basis
            # The columns of G in the renderer's row order, so a drag writes without a gather.
            order = renderer.vertex_order
            imaginary = basis.imaginary_columns
            self._dense = Columns(
                np.asfortranarray(basis.columns[order]),
                None if imaginary is None else np.asfortranarray(imaginary[order]),
                order,
            )
            self._drawn = None
            self._field = None
            self._preview = Preview()
            if basis.preview is not None:
                renderer.set_preview_mesh(basis.preview.vertices, basis.preview.triangles)
                rows = basis.preview.basis[renderer.preview_vertex_order]
                self._preview.columns = Columns(
                    np.asfortranarray(rows.real, dtype=np.float32),
                    np.asfortranarray(rows.imag, dtype=np.float32) if np.iscomplexobj(rows) else None,
                )
        self.previewing = False
        if not self.mesh_matches(state):
            return
        if self._preview_wanted(state):
            self._update_preview(state)
        else:
            self._update_positions(state)
        self._update_field(state)

    def _update_fill(self, state: AppState) -> None:
        """The backdrop with the original position filled (`app.warp.fill`), for the committed cage: a
        source drag in progress or a new cage being drawn keep the last one."""
        document = state.document
        cage = document.history.current.cage
        key = (cage.tobytes(), document.fill, document.outside)
        if key == self._fill_key:
            return
        self._fill_key = key
        try:
            set_fill(self.renderer, document.image, cage, document.fill, document.outside)
        except ValueError:  # no valid cage (yet): the plain image
            self.renderer.set_backdrop_image(None)

    def _preview_wanted(self, state: AppState) -> bool:
        """Whether this frame draws the preview mesh: a dense mesh's image while its target or the
        view moves."""
        moving = (
            state.selection.drag is not None and state.selection.drag.kind in TARGET_DRAGS
        ) or state.playback.playing
        return (
            (moving or state.display.viewport_moving)
            and self._preview.columns is not None
            and state.display.view_mode == "image"
            and state.selection.edit_mode in WARPING_MODES
            and not state.display.show_wireframe
        )

    def _update_preview(self, state: AppState) -> None:
        """The preview mesh's positions, G' @ P' (~20k rows: cheaper than any update of the dense
        mesh), or with fold-free on, the fold-free frames' on it."""
        self.previewing = True
        target = state.document.live.target
        preview = self._preview
        fold_free = self._fold_free_frames_wanted(state)
        if (
            preview.target is not None
            and np.array_equal(preview.target, target)
            and preview.fold_free == fold_free
            and not (fold_free and preview.frames.catching_up)
        ):
            return  # a pan or zoom: the positions are those of the last frame
        started = time.perf_counter()
        if fold_free:
            basis = self._basis
            frames = preview.frames
            coarse = PreviewBasis(f"{basis.key} preview", basis.preview, basis.preview.basis)
            positions = frames.positions(coarse, target, moving=True)
            state.compute.mesh_proof, state.compute.folded_count = frames.proof, frames.proof.turned_over
            self.renderer.set_preview_positions(
                positions[self.renderer.preview_vertex_order].astype(np.float32)
            )
        else:
            self.renderer.set_preview_positions(
                combined_columns(preview.columns.columns, target, preview.columns.imaginary)
            )
        preview.target, preview.fold_free = np.array(target), fold_free
        # The dense mesh is left as it was (`_drawn` with it): once the motion stops it gets
        # the exact positions if the target changed meanwhile.
        self.update_ms = 1e3 * (time.perf_counter() - started)

    def _fold_free_frames_wanted(self, state: AppState) -> bool:
        """Whether this frame's positions come from `app.viewer.fold_free_frames`: the document asks
        for fold-free, the basis drawn is the harmonic kernel's, keyframes are not playing."""
        live = state.document.live
        return live.fold_free and self._basis.kernel == HARMONIC_KERNEL and not state.playback.playing

    def _update_fold_free(self, state: AppState) -> None:
        """Positions proven fold-free on the mesh (`app.viewer.fold_free_frames`): the certified
        continuous map of this target once the background check has it (if the mesh map of it is a
        bijection too), else this frame's drag step; their count of turned-over triangles (0)."""
        target, frames = state.document.live.target, self.fold_free_frames
        certified = _fold_free_positions(state)
        drawn, certified_drawn = self._drawn if self._drawn is not None else (None, None)
        if (
            drawn is not None
            and np.array_equal(drawn, target)
            and certified_drawn is not None
            and (certified is None or certified is certified_drawn or certified is frames.refused)
            and not frames.catching_up
        ):
            return
        started = time.perf_counter()
        if (
            certified is not None
            and certified is not frames.refused
            and frames.adopt(self._basis, target, certified)
        ):
            positions = certified
        else:
            dragging = state.selection.drag is not None and state.selection.drag.kind in TARGET_DRAGS
            positions = frames.positions(self._basis, target, dragging)
        state.compute.mesh_proof = frames.proof
        state.compute.folded_count = frames.proof.turned_over
        self._positions = positions[self._dense.order].astype(np.float32)
        self._exact = True
        self.renderer.set_ordered_positions(self._positions)
        self._fold_check = (self.renderer.revision, None)
        self._drawn = (np.array(target), positions)
        self.update_ms = 1e3 * (time.perf_counter() - started)

    @property
    def catching_up(self) -> bool:
        """The fold-free frames have not yet brought the boundary onto the target curve: the window
        draws again without waiting for input."""
        frames = self._preview.frames if self.previewing else self.fold_free_frames
        return frames.catching_up

    def _update_positions(self, state: AppState) -> None:
        if self._fold_free_frames_wanted(state):
            self._update_fold_free(state)
            return
        if self.fold_free_frames.proof is not None:
            self.fold_free_frames.forget()
            state.compute.mesh_proof = None
        basis, target = self._basis, state.document.live.target
        dragging = state.selection.drag is not None and state.selection.drag.kind in TARGET_DRAGS
        drawn, fold_free_drawn = self._drawn if self._drawn is not None else (None, None)
        fold_free = None if state.playback.playing else _fold_free_positions(state)
        if (
            drawn is not None
            and np.array_equal(drawn, target)
            and (self._exact or dragging or state.playback.playing)
            and fold_free is fold_free_drawn
        ):
            return
        started = time.perf_counter()
        changed = None if drawn is None else np.flatnonzero(np.any(drawn != target, axis=1))
        # The rank-one update adds to the plain map's positions only.
        incremental = fold_free_drawn is None and changed is not None and 0 < len(changed) <= 4
        if fold_free is not None:
            # The certified fold-free map of this target (`app.viewer.fold_free`), once a drag pauses.
            self._positions = fold_free[self._dense.order].astype(np.float32)
            self._exact = True
            self._count_folds(state, fold_free)
        elif dragging and incremental and self._positions is not None:
            # The per-drag path: one column of G per moved point, O(V) work for any n.
            positions = self._positions.T  # (2, V) views of the two coordinates
            for i in changed:
                delta = (target[i] - drawn[i]).astype(np.float32)
                dense = self._dense
                imaginary = None if dense.imaginary is None else dense.imaginary[:, i]
                _add_column(positions, dense.columns[:, i], imaginary, delta)
            self._exact = False
        elif state.playback.playing:
            # Every frame of playback: float32 and no BLAS (`combined_columns`); the exact product,
            # and the count of folded triangles (which costs more than the product), when it stops.
            self._positions = combined_columns(self._dense.columns, target, self._dense.imaginary)
            self._exact = False
        else:
            deformed = deform(basis.basis, target)
            self._positions = deformed[self._dense.order].astype(np.float32)
            self._exact = True
            self._count_folds(state, deformed)
        self.renderer.set_ordered_positions(self._positions)
        self._fold_check = (self.renderer.revision, None)
        self._drawn = (np.array(target), fold_free)
        self.update_ms = 1e3 * (time.perf_counter() - started)

    def _may_fold(self) -> bool:
        """Whether the fold pass could mark anything on the mesh drawn (`WarpRenderer.may_fold`);
        True whenever the positions drawn are not the ones this scene wrote last (the preview's,
        an export's)."""
        revision = self.renderer.revision
        check = self._fold_check
        if self.previewing or self._positions is None or check is None or check[0] != revision:
            return True
        if check[1] is None:
            self._fold_check = (revision, self.renderer.may_fold(self._positions))
        return self._fold_check[1]

    def _count_folds(self, state: AppState, deformed: np.ndarray) -> None:
        import core

        state.compute.folded_count = int(np.count_nonzero(core.folded_triangles(self._basis.mesh, deformed)))

    def _update_field(self, state: AppState) -> None:
        mode = VIEW_MODES[state.display.view_mode]
        if mode.field is not None:
            self._field = mode.field(state, self._basis, self.renderer, self._field)

    def invalidate_positions(self) -> None:
        """Someone else wrote the position buffer: recompute it at the next `sync`."""
        self._drawn = None

    def deformation(self, state: AppState):
        """The `app.warp.pipeline.Deformation` of the mesh drawn (what `warp` renders: the fold-free map
        when the document asks for it), or None without a matching mesh."""
        if not self.mesh_matches(state):
            return None
        return self._basis.deformation(fold_free=state.document.live.fold_free)

    def draw(self, state: AppState, framebuffer_size: tuple[int, int], pixel_ratio: float = 1.0) -> None:
        """Draw the canvas into the bound framebuffer: backdrop, mesh, overlays.

        Before the basis of a warped view arrives, its backdrop alone (`_mesh_pending`).

        A frame that shows what the frame before showed (the same `WarpRenderer.revision`,
        view and settings: the pointer moved, a widget changed) draws the backdrop and
        the mesh into a layer of their own, and the frames after it copy that layer and
        draw only the overlays on it: a software rasteriser draws a 400k-vertex mesh in
        ~230 ms, the copy takes a millisecond or two.  A frame that changes them (a
        drag) draws straight into the bound framebuffer, without the layer's extra
        pass and copy (~7 ms a frame at the default 6k vertices).
        """
        renderer = self.renderer
        ctx = renderer.ctx
        view = View(
            state.display.viewport.scale * pixel_ratio,
            tuple(v * pixel_ratio for v in state.display.viewport.offset),
        )
        meshed = self.mesh_matches(state)
        content = VIEW_MODES[state.display.view_mode].drawn
        warps = state.selection.edit_mode in WARPING_MODES or content != "image"
        warped = meshed and warps
        # The faded source image costs a full textured pass of a software rasteriser: only on request.
        opacity = (
            (1.0 if state.document.outside == "original" else state.display.backdrop_opacity)
            if warped or _mesh_pending(state, meshed, warps)
            else 1.0
        )
        wireframe = state.display.show_wireframe
        folds = state.display.show_folds and content != "distortion"  # that view shows folds per vertex
        size = (int(framebuffer_size[0]), int(framebuffer_size[1]))
        key = (renderer.revision, view, size, warped, content, wireframe, folds, self.previewing, opacity)

        def draw_layer() -> None:
            ctx.clear(*BACKGROUND, 1.0)
            if opacity > 0:
                renderer.draw_backdrop(view, size, opacity)
            if warped:
                # Skipping a fold pass that would mark nothing draws the same pixels.
                marked = folds and self._may_fold()
                renderer.draw(
                    view, size, content=content, wireframe=wireframe, folds=marked, preview=self.previewing
                )

        layer = self._layer
        if key == layer.key and layer.framebuffer is not None and layer.framebuffer.size == size:
            ctx.copy_framebuffer(ctx.fbo, layer.framebuffer)
        elif key == layer.drawn:  # the same picture again: keep it for the frames to come
            target, viewport = ctx.fbo, ctx.viewport
            framebuffer = self._layer_framebuffer(size)
            framebuffer.use()
            draw_layer()
            layer.key = key
            target.use()
            ctx.viewport = viewport
            ctx.copy_framebuffer(target, framebuffer)
        else:
            draw_layer()
        layer.drawn = key
        if state.display.show_overlay:
            segments, points = overlay_arrays(state)
            renderer.set_overlay(segments, points)
            renderer.draw_overlay(view, size)

    def _layer_framebuffer(self, size: tuple[int, int]):
        """The framebuffer of the backdrop-and-mesh layer, (re)made at `size`."""
        layer = self._layer
        if layer.framebuffer is None or layer.framebuffer.size != size:
            self.release()
            layer.framebuffer = self.renderer.ctx.simple_framebuffer(size, components=4)
        return layer.framebuffer

    def release(self) -> None:
        """Free the layer's framebuffer (the renderer is the caller's to release)."""
        if self._layer.framebuffer is not None:
            self._layer.framebuffer.release()
        self._layer.framebuffer = None
