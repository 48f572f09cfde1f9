"""The viewer's model: immutable edit snapshots, their undo history, and `AppState` in small parts.

An edit (moving, inserting or deleting a control point, fitting, subdividing,
choosing a kernel, opening an image) replaces the whole `Snapshot`; the `History`
keeps the snapshots, so undo and redo swap whole states and can never get out of
step with what was drawn.  `AppState` holds the `Document` (history, live snapshot,
image, session file) and the state that undo does not touch, each part with one
reason to change: `Selection` (edit mode, chosen handles, drag), `Display`
(viewport, view mode, overlays), `Playback` (timeline), `Compute` (basis functions
and precompute), `Status` (messages, prompts, quit) and `Screen` (window geometry).

Coordinates are image pixels, x to the right, y down, origin at the image's
top-left corner, like the cage and session files.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from app.render.viewport import View
from app.warp.keyframes import DEFAULT_INTERPOLATION, INTERPOLATIONS, Keyframe, sorted_keyframes
from core import KERNEL_TABLE, PARAMETERIZATIONS, PARAMETERIZED_KERNELS, SHIFTS

#: Parameters of the ``power`` kernel family (Eq. 19) when a session does not say.
DEFAULT_POWER = 4.0
DEFAULT_SHIFT = "mean"

#: What the distortion view shows: log2 det J, or log2 sigma_1 / sigma_2 (app.viewer.distortion_view).
MEASURES = ("area", "conformal")
#: What a left click edits: the target (deform), the source cage, or pins in the picture
#: (`app.viewer.pin_tool`).
EDIT_MODES = ("deform", "cage", "pins")
#: The edit modes that show the warp (the cage mode shows the source).
WARPING_MODES = ("deform", "pins")
#: The drags that move the target: the scene draws their frames as drag frames.
TARGET_DRAGS = ("target", "pin")


def _frozen_points(points, name: str) -> np.ndarray:
    array = np.array(points, dtype=np.float64).reshape(-1, 2)
    if not np.isfinite(array).all():
        raise ValueError(f"{name} contain NaN or infinite values")
    array.setflags(write=False)
    return array


@dataclass(frozen=True)
class Pins:
    """The pin tool's part of a `Snapshot` (`app.viewer.pin_tool`), never modified in place.

    Attributes
    ----------
    points : tuple of ((float, float), (float, float))
        Each pin's source point ``at`` and where the warp takes it, ``to``, image pixels.
    bound : float or None
        K >= 1: sigma1/sigma2 <= K in the whole picture (None, or inf: no bound).
    fixed : tuple of int
        Control points moved by hand while there are pins: the pins' solves hold their targets.
    """

    points: tuple = ()
    bound: float | None = None
    fixed: tuple[int, ...] = ()

    def __post_init__(self):
        points = tuple((_pair(at), _pair(to)) for at, to in self.points)
        object.__setattr__(self, "points", points)
        bound = None if self.bound is None else float(self.bound)
        if bound is not None and not bound >= 1.0:  # NaN too
            raise ValueError(f"the pins' bound K must be a number >= 1, got {self.bound!r}")
        object.__setattr__(self, "bound", None if bound == np.inf else bound)
        object.__setattr__(self, "fixed", tuple(sorted({int(i) for i in self.fixed if i >= 0})))

    def replace(self, **changes) -> Pins:
        """A copy with some fields changed."""
        return dataclasses.replace(self, **changes)


def _pair(point) -> tuple[float, float]:
    x, y = (float(v) for v in point)
    if not (np.isfinite(x) and np.isfinite(y)):
        raise ValueError("a pin contains NaN or infinite values")
    return (x, y)


@dataclass(frozen=True, eq=False)
class Snapshot:
    """Everything one edit changes, never modified in place.

    Attributes
    ----------
    image : Path
        The source image file.
    cage : ndarray of shape (n, 2)
        Source control points (read-only); fewer than 3 while a cage is being placed.
    target : ndarray of shape (n, 2)
        Target control points (read-only), one per source point.
    kernel : str
        A name of `app.io.files.kernel_names`.
    power, shift : float, str
        Parameters of the ``power`` kernel (ignored by the others).
    parameterization : str
        One of `PARAMETERIZATIONS`: the boundary parameter of the point kernels'
        integrals (ignored by ``harmonic`` and ``pgw``).
    keyframes : tuple of app.warp.keyframes.Keyframe
        The animation, sorted by time, each target of n points (`app.warp.keyframes`);
        adding, moving or deleting one is an edit like any other.
    interpolation : str
        One of `app.warp.keyframes.INTERPOLATIONS`.
    fold_free : bool
        Deform by the certified fold-free map (`core.fold_free_deform`; ``poisson`` only), as
        sessions' ``"fold_free": true`` asks of ``warp`` and ``animate``.
    outside : str
        What exports show outside the deformed region (`app.warp.framing.OUTSIDES`).
    canvas : str
        What exports frame: ``"source"``, or ``"grow"`` to hold the whole target.
    fill : str
        What fills the source cage's region behind the warp, with outside "original" (`app.warp.fill`).
    background : str
        What exports show where the warp leaves them transparent: ``"none"`` (transparent) or a
        colour as ``--background`` takes it (`app.io.images.colours.parse_colour`).
    pins : Pins
        The pins in the picture, their bound and the control points they hold (`app.viewer.pin_tool`).
    """

    image: Path
    cage: np.ndarray
    target: np.ndarray
    kernel: str = "poisson"  # core.mesh_basis.DEFAULT_KERNEL
    power: float = DEFAULT_POWER
    shift: str = DEFAULT_SHIFT
    keyframes: tuple[Keyframe, ...] = ()
    interpolation: str = DEFAULT_INTERPOLATION
    parameterization: str = "natural"
    fold_free: bool = False
    outside: str = "transparent"
    canvas: str = "source"
    fill: str = "none"
    background: str = "none"
    pins: Pins = field(default_factory=Pins)

    def __post_init__(self):
        cage = _frozen_points(self.cage, "cage")
        target = _frozen_points(self.target, "target")
        if cage.shape != target.shape:
            raise ValueError(f"target has {len(target)} control points but cage has {len(cage)}")
        if self.shift not in SHIFTS:
            raise ValueError(f"shift must be one of {', '.join(SHIFTS)}, got {self.shift!r}")
        if self.parameterization not in PARAMETERIZATIONS:
            raise ValueError(
                f"parameterization must be one of {', '.join(PARAMETERIZATIONS)}, "
                f"got {self.parameterization!r}"
            )
        if self.interpolation not in INTERPOLATIONS:
            raise ValueError(
                f"interpolation must be one of {', '.join(INTERPOLATIONS)}, got {self.interpolation!r}"
            )
        object.__setattr__(self, "keyframes", sorted_keyframes(self.keyframes, len(cage)))
        object.__setattr__(self, "image", Path(self.image))
        object.__setattr__(self, "cage", cage)
        object.__setattr__(self, "target", target)
        object.__setattr__(self, "power", float(self.power))
        if any(i >= len(cage) for i in self.pins.fixed):  # a fixed point of a cage with more points
            object.__setattr__(
                self, "pins", self.pins.replace(fixed=[i for i in self.pins.fixed if i < len(cage)])
            )

    @property
    def n(self) -> int:
        """Number of control points."""
        return len(self.cage)

    @property
    def time_span(self) -> tuple[float, float] | None:
        """(first, last) keyframe time in seconds, or None without keyframes."""
        return (self.keyframes[0].time, self.keyframes[-1].time) if self.keyframes else None

    def kernel_params(self) -> dict:
        """Keyword parameters of the kernel for `core.mesh_basis_functions`."""
        settings = {"power": self.power, "shift": self.shift}  # the power family's (Eq. 19)
        return {name: settings[name] for name in KERNEL_TABLE[self.kernel].parameters if name in settings}

    @property
    def parameterized(self) -> bool:
        """Whether the kernel depends on the boundary's parameterization (a point kernel)."""
        return self.kernel in PARAMETERIZED_KERNELS

    def basis_params(self) -> dict:
        """Keyword arguments of `core.mesh_basis_functions` besides the kernel: `kernel_params`
        and, for the point kernels, a parameterization other than the natural one."""
        params = self.kernel_params()
        if self.parameterized and self.parameterization != "natural":
            params["parameterization"] = self.parameterization
        return params

    def replace(self, **changes) -> Snapshot:
        """A copy with some fields changed."""
        return dataclasses.replace(self, **changes)

    def __eq__(self, other) -> bool:
        if not isinstance(other, Snapshot):
            return NotImplemented
        return (
            self.image == other.image
            and self.kernel == other.kernel
            and self.power == other.power
            and self.shift == other.shift
            and np.array_equal(self.cage, other.cage)
            and np.array_equal(self.target, other.target)
            and self.keyframes == other.keyframes
            and self.interpolation == other.interpolation
            and self.parameterization == other.parameterization
            and self.fold_free == other.fold_free
            and self.settings() == other.settings()
            and self.pins == other.pins
        )

    def settings(self) -> tuple[str, str, str, str]:
        """(outside, canvas, fill, background): what the export shows around the warp."""
        return (self.outside, self.canvas, self.fill, self.background)

    __hash__ = None  # mutable-looking arrays inside: compare, do not hash


class History:
    """Undo and redo over whole `Snapshot` states.

    Parameters
    ----------
    initial : Snapshot
        The current state (before any edit, or the one a session restored).
    limit : int
        Most undo steps kept; the oldest are dropped.
    undo, redo : list of Snapshot, optional
        Steps restored from a session file, in the order of `undo_steps` and `redo_steps`.
    """

    def __init__(
        self,
        initial: Snapshot,
        limit: int = 1000,
        undo: list[Snapshot] | None = None,
        redo: list[Snapshot] | None = None,
    ):
        self._undo: list[Snapshot] = list(undo or [])[-limit:]
        self._redo: list[Snapshot] = list(redo or [])
        self._current = initial
        self.limit = limit

    @property
    def undo_steps(self) -> tuple[Snapshot, ...]:
        """The states Ctrl+Z goes back to, oldest first."""
        return tuple(self._undo)

    @property
    def redo_steps(self) -> tuple[Snapshot, ...]:
        """The states redo goes forward to, the next one last."""
        return tuple(self._redo)

    @property
    def current(self) -> Snapshot:
        """The state after the last edit (or undo, or redo)."""
        return self._current

    @property
    def can_undo(self) -> bool:
        return bool(self._undo)

    @property
    def can_redo(self) -> bool:
        return bool(self._redo)

    def push(self, snapshot: Snapshot) -> bool:
        """Record an edit; returns False (and records nothing) if nothing changed."""
        if snapshot == self._current:
            return False
        self._undo.append(self._current)
        del self._undo[: -self.limit]
        self._redo.clear()
        self._current = snapshot
        return True

    def undo(self) -> Snapshot | None:
        """Step back; returns the new current state, or None if there is nothing to undo."""
        if not self._undo:
            return None
        self._redo.append(self._current)
        self._current = self._undo.pop()
        return self._current

    def redo(self) -> Snapshot | None:
        """Step forward again; returns the new current state, or None if there is nothing to redo."""
        if not self._redo:
            return None
        self._undo.append(self._current)
        self._current = self._redo.pop()
        return self._current


@dataclass
class Drag:
    """A mouse drag in progress.

    Attributes
    ----------
    kind : {"target", "source", "pin", "pan", "band", "fit_rect"}
        What the drag moves ("pin": a pin's ``to``, the target following by the pins' solve;
        "band": a rubber band that selects the handles inside it; "fit_rect": the rectangle
        around a photograph's subject for "Fit cage").
    index : int
        The control point (the pin) under the cursor (-1 for a pan or a band).
    grab : ndarray of shape (2,)
        Control point minus cursor, image pixels, so that the point does not jump
        to the cursor; for a pan, the cursor's window position at the last event;
        for a band, the window position where it started.
    before : Snapshot
        The state when the drag started: Esc goes back to it.
    moved : bool
        Whether the cursor moved since the press.
    indices : tuple of int
        Every control point the drag moves together (the selection, `index` among them).
    selection : frozenset of int
        The selection when the drag started (a band with Shift adds to it; Esc restores it).
    solved : tuple
        A pin drag: the pins the live target was last solved for (`app.viewer.pin_tool.follow`).
    """

    kind: str
    index: int
    grab: np.ndarray
    before: Snapshot
    moved: bool = False
    indices: tuple[int, ...] = ()
    selection: frozenset = frozenset()
    solved: tuple = ()


@dataclass
class Drawing:
    """A new cage being placed point by point (the "new cage" mode), not yet in the history.

    The points placed so far are ``AppState.live.cage`` (and ``target``).

    Attributes
    ----------
    before : Snapshot
        The document before the new cage was started: Esc goes back to it, Enter
        replaces its cage and target with the new points.
    closed : bool
        Whether the curve was closed (first point clicked, or Enter).
    last_click : tuple of float or None
        (time, x, y) of the last placement, to tell a double click.
    clicks : list of (x, y)
        The points clicked, image pixels, in order (`app.viewer.drawing.control_points`
        turns them into the cage's control points).
    corners : list of bool
        Which clicks are sharp corners (Ctrl+click, double click).
    """

    before: Snapshot
    closed: bool = False
    last_click: tuple[float, float, float] | None = None
    clicks: list = field(default_factory=list)
    corners: list = field(default_factory=list)


@dataclass
class BasisResult:
    """Basis functions G of one (cage, mesh, kernel), ready to draw.

    Attributes
    ----------
    key : str
        `app.viewer.precompute.basis_key` of what it was computed for.
    cage : ndarray of shape (n, 2)
        The source control points it belongs to.
    mesh : core.Mesh
        The mesh of the domain: undeformed vertices (V, 2) in image pixels, triangles.
    basis : ndarray of shape (V, n), float64 or complex128
        G; the deformed vertices are ``core.deform(basis, target)``.
    columns : ndarray of shape (V, n), float32, column-major
        G again (its real part), so that one column (one control point's influence)
        is contiguous for the per-drag rank-one update.
    imaginary_columns : ndarray of shape (V, n), float32, column-major, or None
        The imaginary part of complex coordinates (Cauchy–Green), None for real ones.
    kernel : str
        The kernel it was computed with (shown while another one is computed).
    seconds : float
        Wall time of the precompute (0 when it came from a cache).
    gradients : ndarray of shape (V, n, 2) or None
        grad G at the vertices (NaN on the boundary) for the distortion view, if
        they were asked for and the kernel has them (a point kernel).
    preview : PreviewMesh or None
        A lighter mesh drawn while a handle moves, for a dense mesh
        (`app.viewer.precompute.PREVIEW_FROM_VERTICES` vertices or more).
    """

    key: str
    cage: np.ndarray
    mesh: object  # core.Mesh (not imported here: state stays light)
    basis: np.ndarray
    columns: np.ndarray
    kernel: str
    seconds: float
    gradients: np.ndarray | None = None
    preview: PreviewMesh | None = None
    imaginary_columns: np.ndarray | None = None

    def deformation(self, fold_free: bool = False):
        """This basis as an `app.warp.pipeline.Deformation`: what `warp` and the export render (with
        `fold_free`, the certified fold-free map, as ``warp`` with a session's ``"fold_free"``)."""
        import core
        from app.warp.pipeline import Deformation

        return Deformation(self.mesh, self.basis, self.kernel, core.ClosedBSpline(self.cage), fold_free)


@dataclass(frozen=True)
class PreviewMesh:
    """A coarser mesh of the same domain and the rows of G that draw on it what the dense mesh draws.

    Attributes
    ----------
    vertices : ndarray of shape (V', 2)
        Undeformed, image pixels.
    triangles : ndarray of shape (T', 3)
    basis : ndarray of shape (V', n), float64
        ``core.meshes.mesh_transfer.transfer_basis`` of the dense mesh's G: the preview's
        deformed vertices are ``basis @ target``.
    boundary : ndarray of shape (B,), int
        Its boundary loop (the fold-free frames drawn on it: `app.viewer.fold_free_frames`).
    """

    vertices: np.ndarray
    triangles: np.ndarray
    basis: np.ndarray
    boundary: np.ndarray


@dataclass
class Document:
    """The document shown and saved: its history, the live version, the image, the session file,
    and what its exports frame.

    Attributes
    ----------
    history : History
    live : Snapshot
        `history.current`, or the version a drag is changing right now (committed to the
        history when the mouse is released).
    image : ndarray of shape (H, W, 4), uint8
        RGBA pixels of ``live.image``.
    session_path : Path
    session_dirty : bool
        An edit to save now.
    max_edge : float or None
        A forced mesh edge length (None: from the cage's area).
    saved : Snapshot or None
        What the session file holds now (None: not written yet): an autosave of anything
        else is a new version of the file.
    """

    history: History
    live: Snapshot
    image: np.ndarray
    session_path: Path
    session_dirty: bool = False
    max_edge: float | None = None
    saved: Snapshot | None = None

    # The export's settings are the live snapshot's: changing one is an undo step like any edit.
    @property
    def outside(self) -> str:
        return self.live.outside

    @property
    def canvas(self) -> str:
        return self.live.canvas

    @property
    def fill(self) -> str:
        return self.live.fill

    @property
    def background(self) -> str:
        return self.live.background


@dataclass
class Selection:
    """What the mouse edits and holds: the edit mode, the chosen handles, the drag in progress."""

    edit_mode: str = "deform"  # one of EDIT_MODES: what a left click edits
    selected: int | None = None  # the last handle clicked: its basis function is shown
    group: frozenset = frozenset()  # the handles moved together (Shift+click, rubber band)
    hovered: int | None = None
    drag: Drag | None = None
    drawing: Drawing | None = None  # a new cage being placed
    cage_drawing: str = "curve"  # a new cage's clicks: points on the "curve", or "control" points
    fit_rect: bool = False  # "Fit cage" on a photo waits for a rectangle around the subject
    pin: int | None = None  # the pin last clicked (pins mode): Delete removes it


@dataclass
class Display:
    """How the canvas shows the document: the viewport, the view mode and what is drawn over it."""

    viewport: View = field(default_factory=View)
    view_mode: str = "image"  # a name of app.viewer.view_modes.MODES
    distortion_measure: str = "area"  # of the distortion view: "area" (det J) or "conformal"
    distortion: object | None = None  # app.viewer.distortion_view.DistortionSummary of the view shown
    viewport_fitted: bool = True  # the viewport is `fit_view`'s (a window resize fits it again)
    viewport_dirty: bool = False  # a zoom or pan to save soon
    viewport_moving: bool = False  # a pan or a wheel zoom is under way (the window sets it every frame)
    show_folds: bool = True
    show_wireframe: bool = False
    show_overlay: bool = True
    show_help: bool = False
    backdrop_opacity: float = 0.0  # of the source image behind the warp (outside "transparent")
    power_draft: float | None = None  # the power slider while it is dragged
    bound_draft: float | None = None  # the pins' K slider (its position, 1 - 1/K) while it is dragged


@dataclass
class Playback:
    """The timeline: its time, whether the keyframes play, the keyframe chosen."""

    time: float = 0.0  # seconds
    playing: bool = False  # the keyframes play (Space)
    loop: bool = True  # playback starts again at the first keyframe after the last
    keyframe: int | None = None  # the keyframe selected on the timeline
    time_draft: float | None = None  # the selected keyframe's time field while it is dragged
    fps: float = 30.0  # the session's frame grid (`app.viewer.frame_grid`): times sit at whole frames


@dataclass
class Compute:
    """The basis functions drawn and the precompute of the wanted ones."""

    basis: BasisResult | None = None  # the result drawn (perhaps of another kernel)
    progress: float | None = None  # fraction of the running precompute, None when idle
    progress_label: str = ""
    basis_error: str = ""  # why the wanted basis functions could not be computed
    folded_count: int | None = None
    check: WarpCheck | None = None  # the last injectivity check applied (`app.viewer.fold_free`)
    check_progress: float | None = None  # share of the path proven of the fold-free map being made
    mesh_proof: object = None  # app.viewer.fold_free_frames.MeshProof of the fold-free mesh drawn


@dataclass(frozen=True, eq=False)
class WarpCheck:
    """What the background check proved about one target's warp (`app.viewer.fold_free`).

    Attributes
    ----------
    key : str
        `app.viewer.fold_free.check_key` of the cage, target, switch and mesh checked.
    fold_free : bool
        The fold-free map was computed (not the plain one).
    injective : bool
        Proven fold-free (`core.InjectivityCertificate.injective`).
    sigma2_min : float
        A proven lower bound of the Jacobian's smaller singular value; 0 when nothing is proven.
    where : ndarray of shape (K, 2)
        Points of the source domain, image pixels, where the proof fails.
    marks : ndarray of shape (K, 2)
        Their images under the map shown (where the canvas marks them), image pixels.
    text : str
        The certificate's one-line summary, or why the fold-free map could not be made.
    positions : ndarray of shape (V, 2), optional
        The fold-free map at the mesh's vertices (with `fold_free`).
    seconds : float
        Time the worker took.
    on_mesh : bool
        What is proven is the mesh's piecewise-linear map (every triangle positive, the boundary
        simple), not the continuous map's σ₂ bound (`core.InjectivityCertificate.on_mesh`).
    """

    key: str
    fold_free: bool
    injective: bool
    sigma2_min: float
    where: np.ndarray
    marks: np.ndarray
    text: str
    positions: np.ndarray | None
    seconds: float
    on_mesh: bool = False


@dataclass
class Status:
    """What the viewer tells the user, what it asks, and whether it quits."""

    message: str = ""
    message_is_error: bool = False
    message_owner: Snapshot | None = None  # the document the message was said about (`status_message`)
    open_prompt: str | None = None  # the path typed into the open prompt (no dialog program)
    export_prompt: str | None = None  # the path typed into the export prompt (no dialog program)
    cage_prompt: str | None = None  # the path typed into Save cage's prompt (no dialog program)
    target_prompt: str | None = None  # the path typed into Save target's prompt (no dialog program)
    frame_ms: list[float] = field(default_factory=list)
    #: (median frame, median drag frame) in ms, as ``--stats`` reports them (the window updates them).
    frame_figures: tuple[float, float] | None = None
    quit: bool = False

    def say(self, message: str, error: bool = False, owner: Snapshot | None = None) -> None:
        """Show `message` in the status line, for as long as `owner` is the document shown."""
        self.message = " ".join(str(message).split())
        self.message_is_error = error
        self.message_owner = owner


@dataclass
class Screen:
    """The window as the canvas sees it, in window pixels."""

    cursor: tuple[float, float] = (0.0, 0.0)
    window_size: tuple[int, int] = (1280, 1024)
    canvas_left: float = 0.0  # hidden under the side panel
    panel_bottom: float = (
        0.0  # the side panel's bottom edge: a press above it, left of canvas_left, is the panel's
    )


@dataclass
class AppState:
    """Everything the viewer knows, read and written by `gui`, the controller and the window once
    per frame, in small parts that each change for one reason (napari's ViewerModel of small
    models): the document, the selection, the display, the playback, the compute, the status and
    the screen."""

    document: Document
    selection: Selection = field(default_factory=Selection)
    display: Display = field(default_factory=Display)
    playback: Playback = field(default_factory=Playback)
    compute: Compute = field(default_factory=Compute)
    status: Status = field(default_factory=Status)
    screen: Screen = field(default_factory=Screen)

    @classmethod
    def opened(cls, history: History, image: np.ndarray, session_path: Path) -> AppState:
        """The state of a document just opened: `history`'s current snapshot, live."""
        return cls(Document(history, history.current, image, Path(session_path)))

    def say(self, message: str, error: bool = False) -> None:
        """Show `message` in the status line, for as long as the document stays the one it is about."""
        self.status.say(message, error, self.document.history.current)

    def status_message(self) -> str:
        """What the status line says: the last message, unless the document changed since (an edit,
        an undo, a redo): "moved 8 control points" belongs to the state that move made."""
        status = self.status
        return status.message if status.message_owner is self.document.history.current else ""
