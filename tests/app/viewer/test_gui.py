"""app.viewer.gui: what the status line says (the widgets themselves are tested through the window)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np

from app.render.viewport import View
from app.viewer.gui import status_kernel, status_summary
from app.viewer.state import AppState, Display, Document, History, Snapshot

SQUARE = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]])


def test_the_status_line_names_the_kernel_shown_while_another_is_computed():
    snapshot = Snapshot(Path("square.png"), SQUARE, SQUARE)
    document = Document(History(snapshot), snapshot, np.zeros((120, 120, 4), np.uint8), Path("s.json"))
    state = AppState(document, display=Display(viewport=View(1.0, (0, 0))))
    assert status_kernel(state) == "poisson"  # nothing drawn yet: the one being computed
    state.compute.basis = SimpleNamespace(kernel="poisson")
    assert status_kernel(state) == "poisson"
    state.document.live = snapshot.replace(kernel="harmonic")
    assert status_kernel(state) == "poisson, switching to harmonic..."
    state.document.live = snapshot.replace(kernel="power", power=3.0, shift="mean")
    assert status_kernel(state) == "poisson, switching to power (k=3, shift mean)..."


def square_state() -> AppState:
    snapshot = Snapshot(Path("square.png"), SQUARE, SQUARE)
    document = Document(History(snapshot), snapshot, np.zeros((120, 120, 4), np.uint8), Path("s.json"))
    return AppState(document, display=Display(viewport=View(1.0, (0, 0))))


def test_the_status_line_gives_the_precompute_time_of_the_basis_drawn_and_the_stats_frame_times():
    state = square_state()
    assert (
        status_summary(state) == "poisson | no mesh yet | zoom 100 % | precompute - | frame - | fold-free: -"
    )
    mesh = SimpleNamespace(vertices=np.zeros((6332, 2)))
    state.compute.basis = SimpleNamespace(kernel="pgw", mesh=mesh, preview=None, seconds=1.15)
    state.document.live = state.document.live.replace(kernel="pgw")
    state.status.frame_figures = (64.9, 0.0)
    summary = status_summary(state)
    assert summary.endswith("precompute 1.15 s | frame 64.9 ms | no fold-free proof (poisson only)")
    # Back to a basis remembered from before: its own time, not the last one computed.
    state.compute.basis = SimpleNamespace(kernel="poisson", mesh=mesh, preview=None, seconds=0.31)
    state.document.live = state.document.live.replace(kernel="poisson")
    state.status.frame_figures = (20.5, 64.9)
    assert status_summary(state).endswith(
        "| precompute 0.31 s | frame 20.5 ms, dragging 64.9 ms | checking folds..."
    )


def test_a_message_belongs_to_the_document_it_was_said_about():
    from app.viewer import commands, controller

    state = square_state()
    state.say("restored square.png from the session; --fresh starts over")
    assert state.status_message().startswith("restored")
    state.selection.group = frozenset({0, 1})
    controller.pointer(state, "press", 0.0, 0.0)
    controller.pointer(state, "move", 10.0, 5.0)
    assert state.status_message().startswith("restored")  # a drag in progress changes no document yet
    controller.pointer(state, "release", 10.0, 5.0)
    assert state.status_message() == "moved 2 control points"
    commands.command(state, "undo")
    assert state.status_message() == "undone: moved 2 target points"  # not what the undone edit said
    commands.command(state, "undo")
    assert state.status_message() == "nothing to undo"  # said about the document shown
    commands.command(state, "redo")
    assert state.status_message() == "redone: moved 2 target points"


def test_the_status_line_spells_what_the_font_cannot_draw():
    from app.viewer.gui import in_the_font

    assert in_the_font("fold-free, proven (σ₂ ≥ 0.21)") == "fold-free, proven (sigma2 >= 0.21)"
    assert in_the_font("k ≤ 0.9, σ₁/σ₂ × 2 …") == "k <= 0.9, sigma1/sigma2 x 2 ..."
    assert in_the_font("plain text") == "plain text"
