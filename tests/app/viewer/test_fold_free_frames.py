"""app.viewer.fold_free_frames: with fold-free on, every mesh drawn is proven fold-free, the plain map
where it is; the status line names what is proven; --stats counts the drag frames and times the
proof after a release (app.viewer.milestones)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from support.fold_free_checks import ASSETS, STARFISH, strong_target

import core
from app.viewer import fold_free_frames
from app.viewer.fold_free_frames import FoldFreeFrames, MeshProof, plain_positions
from app.viewer.gui import status_check
from app.viewer.milestones import Milestones
from app.viewer.precompute import compute, make_request, result_from_message
from app.viewer.state import AppState, Drag, History, Snapshot


@pytest.fixture(autouse=True)
def private_cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("TRANSFINITE_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))


@pytest.fixture(scope="module")
def basis():
    """The starfish demo's basis on a mesh of edge 12 px."""
    snapshot = Snapshot(ASSETS / "starfish.png", STARFISH, STARFISH)
    request = make_request(snapshot, 12.0)
    return result_from_message(request.key, compute(request))


def _state(basis, target, fold_free: bool = True) -> AppState:
    snapshot = Snapshot(ASSETS / "starfish.png", STARFISH, target, fold_free=fold_free)
    state = AppState.opened(History(snapshot), np.zeros((480, 640, 4), np.uint8), Path("/tmp/s.json"))
    state.compute.basis = basis
    return state


def test_plain_positions_are_the_basis_times_the_target(basis):
    target = strong_target()
    np.testing.assert_allclose(plain_positions(basis.basis, target), basis.basis @ target, rtol=0, atol=1e-9)


def test_a_strong_drag_draws_only_proven_frames_and_catches_up_at_rest(basis):
    """The strong drag in 20 moving frames, then frames at rest: each proven a bijection with nothing
    folded by `core.folded_triangles`, the plain map's own positions while it is fold-free, and once
    caught up the boundary on the target curve."""
    mesh, frames = basis.mesh, FoldFreeFrames()
    plain_folds = np.count_nonzero(core.folded_triangles(mesh, basis.basis @ strong_target()))
    assert plain_folds > 0
    for fraction in np.linspace(0.05, 1.0, 20):
        target = STARFISH + fraction * (strong_target() - STARFISH)
        positions = frames.positions(basis, target, moving=True)
        assert core.prove_mesh_bijection(positions, mesh.triangles, mesh.boundary).proven
        assert np.count_nonzero(core.folded_triangles(mesh, positions)) == 0
        assert frames.proof.turned_over == 0
    for _ in range(200):
        if not frames.catching_up:
            break
        positions = frames.positions(basis, target, moving=False)
        assert np.count_nonzero(core.folded_triangles(mesh, positions)) == 0
    assert not frames.catching_up and frames.proof.proves(target)
    np.testing.assert_array_equal(
        positions[mesh.boundary], plain_positions(basis.basis, target)[mesh.boundary]
    )
    assert not frames.proof.proves(STARFISH)


def test_given_the_time_every_frame_of_a_strong_drag_is_on_the_target_curve(basis, monkeypatch):
    """The strong drag in 20 moving frames, each given 5 s at most (a few substeps: ~0.1 s): every
    frame proven fold-free with its boundary on the target curve (no lag), none catching up."""
    monkeypatch.setattr(fold_free_frames, "DRAG_BUDGET", 5.0)
    mesh, frames = basis.mesh, FoldFreeFrames()
    for fraction in np.linspace(0.05, 1.0, 20):
        target = STARFISH + fraction * (strong_target() - STARFISH)
        positions = frames.positions(basis, target, moving=True)
        assert frames.proof.proves(target) and frames.proof.lag == 0.0 and not frames.catching_up
        assert np.count_nonzero(core.folded_triangles(mesh, positions)) == 0
        np.testing.assert_array_equal(
            positions[mesh.boundary], plain_positions(basis.basis, target)[mesh.boundary]
        )
    assert not frames.proof.proves(STARFISH)


def test_a_certified_map_is_drawn_only_if_its_mesh_map_is_a_bijection(basis):
    frames = FoldFreeFrames()
    folding = plain_positions(basis.basis, strong_target())
    assert not frames.adopt(basis, strong_target(), folding) and frames.refused is folding
    fold_free = plain_positions(basis.basis, STARFISH)
    assert frames.adopt(basis, STARFISH, fold_free) and frames.proof == MeshProof(STARFISH.tobytes(), True, 0)


def test_the_status_line_names_the_mesh_proof_first_and_never_says_100_percent(basis):
    state = _state(basis, strong_target())
    assert status_check(state) == "computing the fold-free map..."
    state.compute.mesh_proof = MeshProof(strong_target().tobytes(), False, 0)
    assert status_check(state) == "fold-free on the mesh, catching up with the drag..."
    state.compute.mesh_proof = MeshProof(strong_target().tobytes(), True, 0)
    assert status_check(state) == "fold-free on the mesh, proven; computing the fold-free map..."
    state.compute.check_progress = 0.4
    assert status_check(state) == "fold-free on the mesh, proven; fold-free map: 40 % of the way"
    state.compute.check_progress = 0.999  # the path done, its proof still running
    assert status_check(state) == "fold-free on the mesh, proven; proving the fold-free map..."
    state.compute.mesh_proof = MeshProof(STARFISH.tobytes(), True, 0)  # of another target
    assert status_check(state) == "proving the fold-free map..."


def test_stats_count_fold_free_drag_frames_and_time_the_proof_after_release(basis):
    milestones = Milestones(test_mode=False)
    state = _state(basis, strong_target())
    state.selection.drag = Drag("target", 5, np.zeros(2), state.document.live)
    reached = MeshProof(state.document.live.target.tobytes(), True, 0)
    behind = MeshProof(state.document.live.target.tobytes(), False, 0, 1.5)
    for folded, frame_ms, proof in ((0, 12.0, behind), (2, 14.0, None), (0, 13.0, reached)):
        state.compute.folded_count, state.compute.mesh_proof = folded, proof
        state.status.frame_ms.append(frame_ms)
        milestones.frame_done(state, 0)
    state.selection.drag = None
    milestones.checked("fold-free on the mesh, catching up with the drag...", True, 0)
    state.status.frame_ms.append(30.0)
    milestones.frame_done(state, 0)
    milestones.checked("fold-free on the mesh, proven; computing the fold-free map...", True, 0)
    state.status.frame_ms.append(20.0)
    milestones.frame_done(state, 0)
    stats = dict(item.split("=") for item in milestones.statistics(state).split())
    assert stats["fold_free_drag_frames"] == "3" and stats["max_folded_drawn"] == "2"
    assert (
        stats["median_fold_free_drag_frame_ms"] == "13.00" and stats["median_plain_drag_frame_ms"] == "0.00"
    )
    assert stats["fold_free_drag_frames_on_target"] == "1" and stats["max_boundary_lag_px"] == "1.50"
    assert stats["max_fold_free_drag_frame_ms"] == "14.00"
    # From the start of the release's frame (30 ms) to the proof, a frame later.
    assert 30 <= int(stats["proven_after_release_ms"]) < 1000
    assert (
        Milestones(test_mode=False)
        .statistics(state)
        .endswith(
            "proven_after_release_ms=none median_plain_drag_frame_ms=0.00 fold_free_drag_frames_on_target=0 "
            "max_boundary_lag_px=0.00 max_fold_free_drag_frame_ms=0.00"
        )
    )


def test_a_start_that_folds_is_dropped_for_the_source_mesh(basis):
    """Were the last positions kept ever folded, the frame starts from the source mesh instead of
    failing."""
    frames = FoldFreeFrames()
    frames.positions(basis, STARFISH, moving=False)
    frames._positions = plain_positions(basis.basis, strong_target())  # folded: as no frame keeps
    positions = frames.positions(basis, strong_target(), moving=True)
    assert np.count_nonzero(core.folded_triangles(basis.mesh, positions)) == 0
