"""app.viewer.gui: what the status line says (the widgets themselves are tested through the window)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np

from app.viewer.gui import status_kernel
from app.viewer.state import AppState, Display, Document, History, Snapshot
from app.viewport import View

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
