"""What the running viewer reports about itself: one line per milestone on stdout in test mode
(``TRANSFINITE_VIEWER_TEST=1``: ``ready window=ID``, ``basis ...``, ``drawn basis key=K``,
``saved PATH``, ``drag done ...``, ``popup open``, ``spot kernel=X,Y``, ...) for the tests that
drive the real window, and the frame times of ``--stats``."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from app.viewer.state import TARGET_DRAGS, AppState

#: The panel's sections (`app.viewer.gui`), whose headings' centres are announced.
SECTIONS = ("Edit", "Kernel", "Show", "Animation", "File")

#: Seconds between two updates of the status line's frame times (a median of every frame so far).
FIGURES_INTERVAL = 0.5
#: How the status line's fold-free words begin once something is proven: the mesh map's bijection
#: (`app.viewer.gui.MESH_PROVEN`) or the continuous map's certificate (`app.viewer.fold_free.status_text`).
PROVEN = ("fold-free on the mesh, proven", "fold-free, proven")


def frame_statistics(frame_ms: list[float]) -> tuple[int, float, float]:
    """(count, median, 95th percentile) of frame times in ms; zeros without frames."""
    import numpy as np

    if not frame_ms:
        return 0, 0.0, 0.0
    values = np.asarray(frame_ms)
    return len(values), float(np.median(values)), float(np.percentile(values, 95))


@dataclass
class FoldFreeFigures:
    """What --stats says of fold-free drags (`app.viewer.fold_free_frames`).

    Attributes
    ----------
    drag_ms, plain_drag_ms : list of float
        Times (ms) of the frames drawn while a target point was dragged with fold-free on, and off.
    max_folded_drawn : int
        The most turned-over triangles a frame of the first drew.
    on_target : int
        Those of its frames whose boundary was on the target curve (the others caught up later).
    max_lag_px : float
        The farthest (image px) a boundary vertex of those frames was drawn from the target curve.
    proven_after_release_ms : float or None
        ms from the last release with fold-free on to a proof on the status line (None: not yet).
    released_at : float or None
        When that release was (`time.perf_counter`), while its proof is awaited.
    target_dragged : bool
        The last frame was drawn while a target point was dragged.
    """

    drag_ms: list = field(default_factory=list)
    plain_drag_ms: list = field(default_factory=list)
    max_folded_drawn: int = 0
    on_target: int = 0
    max_lag_px: float = 0.0
    proven_after_release_ms: float | None = None
    released_at: float | None = None
    target_dragged: bool = False


class Milestones:
    """The announcements of one viewer, and the frame times of its drags.

    Parameters
    ----------
    test_mode : bool
        Print the milestones (otherwise only ``--stats`` is kept).
    """

    def __init__(self, test_mode: bool):
        self.test_mode = test_mode
        self.announced_ready = False
        self.previewing = False  # the last frame drew the preview mesh
        self.popup_open = False  # an imgui popup (a list) is open: Esc closes it
        self.typing = False  # a text field has the keyboard
        #: What was last announced of the layout and the status line, by name: the panel's bottom
        #: and hidden height ("panel"), the status line's message ("said") and top ("status"), the
        #: section headings and other spots.
        self.shown: dict = {}
        self.check_status = ""  # the status line's fold-free words last announced
        self.fold_free_drawn = False  # the last frame drew the fold-free map
        self.drag_first_frame: int | None = None
        #: Times (ms) of the frames drawn while a control point was dragged, for --stats.
        self.drag_frame_ms: list[float] = []
        #: The fold-free figures of --stats (`FoldFreeFigures`).
        self.fold_free = FoldFreeFigures()
        #: Window points of some widgets (`app.viewer.gui.gui` fills it), announced for the tests.
        self.spots: dict = {}
        self.figures_at = -FIGURES_INTERVAL  # when the status line's frame times were last computed
        #: Lines said before ``ready`` that tests read after it (the first basis, when the worker
        #: had it before the window's first frame was done): said just after ``ready``.
        self.held: list[str] = []
        #: The key of the last basis a frame on screen was drawn with (``drawn basis``).
        self.drawn_basis: str | None = None

    def announce(self, line: str) -> None:
        if self.test_mode and not self.announced_ready and line.startswith("basis "):
            self.held.append(line)
        elif self.test_mode:
            print(line, flush=True)

    def drags(self, state: AppState) -> None:
        """Test mode: the frame times of each drag of a target point, to compare playback with."""
        if not self.test_mode:
            return
        drag = state.selection.drag
        dragging = drag is not None and drag.kind in TARGET_DRAGS
        if dragging and self.drag_first_frame is None:
            self.drag_first_frame = len(state.status.frame_ms)
        elif not dragging and self.drag_first_frame is not None:
            count, median, _ = frame_statistics(state.status.frame_ms[self.drag_first_frame :])
            self.announce(f"drag done frames={count} median_frame_ms={median:.2f}")
            self.drag_first_frame = None

    def widgets(self, popup: bool, typing: bool) -> None:
        """Whether a popup is open and whether a text field takes the keys, announced when it changes."""
        if popup != self.popup_open:
            self.announce(f"popup {'open' if popup else 'closed'}")
        self.popup_open = popup
        if typing != self.typing:
            self.announce(f"text input {'on' if typing else 'off'}")  # keys go to a text field
            self.typing = typing
        panel = self.spots.get("panel")
        if panel is not None and panel != self.shown.get("panel"):  # it settles over the first frames
            self.shown["panel"] = panel
            self.announce(f"spot panel={panel[0]:.0f},{panel[1]:.0f}")

    def checked(self, status: str, fold_free_drawn: bool, folded: int | None) -> None:
        """The status line's fold-free words and whether the fold-free map is drawn (with the mesh's
        folded triangles), announced when they change (`app.viewer.fold_free`); kept for the time
        from a release to a proof (`frame_done`)."""
        if status != self.check_status:
            self.check_status = status
            self.announce(f"status check {status}")
        if fold_free_drawn != self.fold_free_drawn:
            self.fold_free_drawn = fold_free_drawn
            self.announce(f"fold-free {'drawn' if fold_free_drawn else 'off'} folded={folded}")

    def drawn(self, state: AppState, previewing: bool, shown_distortion) -> None:
        """A frame was prepared: the preview mesh switched, or a new distortion summary."""
        if self.test_mode and previewing != self.previewing:
            self.previewing = previewing
            self.announce(f"preview {'on' if previewing else 'off'}")
        summary = state.display.distortion
        if summary is not shown_distortion and state.display.view_mode == "distortion":
            self.announce(
                f"distortion measure={state.display.distortion_measure} folded={summary.folded} "
                f"exact={summary.exact} vertices={summary.vertices} min_det={summary.min_det:.6g} "
                f"at={summary.min_det_at[0]:.1f},{summary.min_det_at[1]:.1f}"
            )

    def frame_done(self, state: AppState, window_id: int, drawn_basis: str | None = None) -> None:
        """The frame's time is in `state.status.frame_ms`; after the first, ``ready`` and the spots.

        `drawn_basis` is the key of the basis the frame, now on screen, was drawn with (None: the
        source image alone): ``drawn basis key=K`` the first time, after ``basis key=K`` (which
        says when it arrived, before a frame drew it), so that a test's screenshot shows it."""
        drag = state.selection.drag
        if drag is not None and drag.kind in (*TARGET_DRAGS, "source"):
            self.drag_frame_ms.append(state.status.frame_ms[-1])
        self._fold_free_frame(state)
        self._update_figures(state)
        if not self.announced_ready:
            self.announced_ready = True
            self.announce(f"ready window={window_id}")
            for name in ("kernel", "arc-length"):
                x, y = self.spots.get(name, (0, 0))
                self.announce(f"spot {name}={x:.0f},{y:.0f}")
            for line in self.held:
                self.announce(line)
            self.held.clear()
        if drawn_basis is not None and drawn_basis != self.drawn_basis:
            self.drawn_basis = drawn_basis
            self.announce(f"drawn basis key={drawn_basis}")
        self._status_line(state)

    def _status_line(self, state: AppState) -> None:
        """Test mode: what the status line says and where its top is, announced when they change."""
        if not self.test_mode:
            return
        said, top = state.status_message(), self.spots.get("status", (0.0, None))[1]
        if said != self.shown.get("said", ""):
            self.announce(f"status said {said}")
        if top is not None and top != self.shown.get("status"):
            self.announce(f"spot status={top:.0f}")
        self.shown.update(said=said, status=top)
        for name in (
            *SECTIONS,
            "files",
            "save target",
            "K rigid",
            "K free",
        ):  # the headings move as sections open and the progress bar goes
            spot = self.spots.get(name)
            if spot is not None and spot != self.shown.get(name):
                self.shown[name] = spot
                self.announce(f"spot {name}={spot[0]:.0f},{spot[1]:.0f}")

    def _fold_free_frame(self, state: AppState) -> None:
        """A frame with fold-free on: a drag frame's time and turned-over triangles; a release starts
        the clock that the status line's proof (`checked`) stops."""
        figures = self.fold_free
        dragged = state.selection.drag is not None and state.selection.drag.kind in TARGET_DRAGS
        fold_free = state.document.live.fold_free
        if dragged and fold_free:
            figures.drag_ms.append(state.status.frame_ms[-1])
            figures.max_folded_drawn = max(figures.max_folded_drawn, state.compute.folded_count or 0)
            proof = state.compute.mesh_proof
            figures.on_target += proof is not None and proof.proves(state.document.live.target)
            figures.max_lag_px = max(figures.max_lag_px, 0.0 if proof is None else proof.lag)
        elif dragged:
            figures.plain_drag_ms.append(state.status.frame_ms[-1])
        if figures.target_dragged and not dragged and fold_free:
            figures.released_at = time.perf_counter() - 1e-3 * state.status.frame_ms[-1]
            figures.proven_after_release_ms = None
        figures.target_dragged = dragged
        if figures.released_at is not None and self.check_status.startswith(PROVEN):
            figures.proven_after_release_ms = 1e3 * (time.perf_counter() - figures.released_at)
            figures.released_at = None
            self.announce(f"proven after release ms={figures.proven_after_release_ms:.0f}")

    def _update_figures(self, state: AppState) -> None:
        """The status line's frame times: what ``--stats`` would report now, twice a second."""
        now = time.perf_counter()
        if now - self.figures_at < FIGURES_INTERVAL:
            return
        self.figures_at = now
        _, median, _ = frame_statistics(state.status.frame_ms)
        _, drag_median, _ = frame_statistics(self.drag_frame_ms)
        state.status.frame_figures = (median, drag_median)

    def statistics(self, state: AppState) -> str:
        """``--stats``: frames=N median_frame_ms=X p95_frame_ms=Y median_drag_frame_ms=Z
        fold_free_drag_frames=N max_folded_drawn=K median_fold_free_drag_frame_ms=X
        proven_after_release_ms=Y (``none``: no release with fold-free on was proven since)
        median_plain_drag_frame_ms=Z (target drags with fold-free off)
        fold_free_drag_frames_on_target=K (fold-free drag frames whose boundary was on the target curve)
        max_boundary_lag_px=D (the farthest a boundary vertex of theirs was drawn from that curve)
        max_fold_free_drag_frame_ms=X (their slowest)."""
        count, median, p95 = frame_statistics(state.status.frame_ms)
        _, drag_median, _ = frame_statistics(self.drag_frame_ms)
        figures = self.fold_free
        fold_free_count, fold_free_median, _ = frame_statistics(figures.drag_ms)
        _, plain_median, _ = frame_statistics(figures.plain_drag_ms)
        proven = figures.proven_after_release_ms
        return (
            f"frames={count} median_frame_ms={median:.2f} p95_frame_ms={p95:.2f} "
            f"median_drag_frame_ms={drag_median:.2f} fold_free_drag_frames={fold_free_count} "
            f"max_folded_drawn={figures.max_folded_drawn} "
            f"median_fold_free_drag_frame_ms={fold_free_median:.2f} "
            f"proven_after_release_ms={'none' if proven is None else f'{proven:.0f}'} "
            f"median_plain_drag_frame_ms={plain_median:.2f} "
            f"fold_free_drag_frames_on_target={figures.on_target} "
            f"max_boundary_lag_px={figures.max_lag_px:.2f} "
            f"max_fold_free_drag_frame_ms={max(figures.drag_ms, default=0.0):.2f}"
        )
