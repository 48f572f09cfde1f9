"""app.viewer.fold_free: the check of the live warp and its fold-free map, asked of a worker, never
shown for an older target; the Fold-free switch, its session key and its status line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from support.fold_free_checks import ASSETS, STARFISH, strong_target  # noqa: F401

import core
from app.io.session import session_from_json, session_json
from app.viewer import commands
from app.viewer.documents import history_of, session_of
from app.viewer.fold_free import (
    PAUSE,
    CheckProgress,
    CheckUpdates,
    compute_check,
    current_check,
    make_check_request,
    status_text,
)
from app.viewer.gui import status_check
from app.viewer.precompute import compute, make_request, result_from_message
from app.viewer.state import AppState, Drag, History, Snapshot, WarpCheck


@pytest.fixture(autouse=True)
def private_cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("TRANSFINITE_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))


@pytest.fixture(scope="module")
def starfish_basis():
    snapshot = Snapshot(ASSETS / "starfish.png", STARFISH, STARFISH)
    request = make_request(snapshot, 12.0)
    return result_from_message(request.key, compute(request))


def opened(basis, target=None, kernel="poisson") -> AppState:
    snapshot = Snapshot(ASSETS / "starfish.png", STARFISH, STARFISH if target is None else target, kernel)
    state = AppState.opened(History(snapshot), np.zeros((480, 640, 4), np.uint8), Path("/tmp/s.json"))
    state.compute.basis = basis
    return state


class StandInWorker:
    """Records the requests; answers what the test hands it (`answer`)."""

    def __init__(self):
        self.requests, self.answers = [], []

    def submit(self, request) -> None:
        self.requests.append(request)

    def poll(self):
        answers, self.answers = self.answers, []
        return answers

    def answer(self, request) -> None:
        self.answers.append(compute_check(request))


def test_the_plain_map_of_a_strong_drag_is_not_proven_and_its_fold_free_map_is(starfish_basis):
    target = strong_target()
    mesh = starfish_basis.mesh
    plain = compute_check(make_check_request(STARFISH, target, False, starfish_basis))
    folded = np.count_nonzero(core.folded_triangles(mesh, core.deform(starfish_basis.basis, target)))
    assert folded > 0 and not plain.injective and plain.positions is None
    assert len(plain.where) > 0 and plain.marks.shape == plain.where.shape
    assert status_text(plain, folded) == "folds near the marked spots"
    check = compute_check(make_check_request(STARFISH, target, True, starfish_basis))
    assert check.injective and check.sigma2_min > 0 and len(check.where) == 0
    assert np.count_nonzero(core.folded_triangles(mesh, check.positions)) == 0
    # The boundary vertices on the target curve at their parameters, exactly as warp's.
    curve = core.ClosedBSpline(target)
    np.testing.assert_allclose(check.positions[mesh.boundary], curve(mesh.boundary_parameters), atol=1e-9)
    # core.fold_free_deform's map is the mesh's own, proven on the mesh (σ₂ of its triangles).
    assert (
        check.on_mesh
        and status_text(check, 0) == f"fold-free on the mesh, proven (σ₂ ≥ {check.sigma2_min:.2g})"
    )


def test_the_status_of_a_fold_free_map_on_a_cornered_cage_says_it_is_proven_and_where_the_mesh_is_coarse():
    """A fold-free map with radial corner discs is a bijection (`core.fold_free_deform`): not "failed";
    triangles of its mesh still turned over are the mesh's, said as such; a path that cannot be
    made is "failed" with the reason."""
    corners = np.array([[0.0, 0.0], [2.0, 1.0], [3.0, 3.0]])
    positions = np.zeros((4, 2))
    cornered = WarpCheck("k", True, False, 0.0123, corners, corners, "proven outside", positions, 0.1)
    assert status_text(cornered, 0) == "fold-free, proven (σ₂ ≥ 0.012 outside 3 corner discs)"
    assert status_text(cornered, 7) == (
        "fold-free, proven (σ₂ ≥ 0.012 outside 3 corner discs); the mesh is too coarse for it in 7 triangles"
    )
    smooth = WarpCheck("k", True, True, 0.21, np.zeros((0, 2)), np.zeros((0, 2)), "proven", positions, 0.1)
    assert (
        status_text(smooth, 2)
        == "fold-free, proven (σ₂ ≥ 0.21); the mesh is too coarse for it in 2 triangles"
    )
    failed = WarpCheck(
        "k", True, False, 0.0, np.zeros((0, 2)), np.zeros((0, 2)), "the path crosses", None, 0.1
    )
    assert status_text(failed, 5) == "fold-free map failed: the path crosses"
    # core.fold_free_deform's own map, proven on the mesh: no σ₂ bound is claimed for it.
    on_mesh = WarpCheck("k", True, True, 0.05, np.zeros((0, 2)), np.zeros((0, 2)), "t", positions, 0.1, True)
    assert status_text(on_mesh, 0) == "fold-free on the mesh, proven (σ₂ ≥ 0.05)"


def test_a_check_of_an_older_target_is_never_applied(starfish_basis):
    state = opened(starfish_basis)
    worker = StandInWorker()
    announced = []
    updates = CheckUpdates(worker, announced.append)
    updates.update(state)
    (first,) = worker.requests
    assert status_check(state) == "checking folds..."
    commands.commit(state, state.document.live.replace(target=strong_target()), "moved")
    worker.answer(first)  # the answer for the target before the edit arrives after it
    updates.update(state)
    assert current_check(state) is None and announced == []
    assert len(worker.requests) == 2 and not np.array_equal(worker.requests[1].target, first.target)
    worker.answer(worker.requests[1])
    updates.update(state)
    assert current_check(state) is state.compute.check and not updates.pending
    assert announced[0].startswith("check fold_free=False injective=False")
    updates.update(state)
    assert len(worker.requests) == 2  # answered: not asked again
    # Undo: the status line no longer shows the moved target's check.
    commands.command(state, "undo")
    assert current_check(state) is None and status_check(state) == "checking folds..."


def test_a_drag_is_checked_once_its_handle_rests(starfish_basis):
    state = opened(starfish_basis)
    now = [0.0]
    worker = StandInWorker()
    updates = CheckUpdates(worker, print, clock=lambda: now[0])
    state.selection.drag = Drag("target", 4, np.zeros(2), state.document.live)
    updates.update(state)
    now[0] = 0.5 * PAUSE
    updates.update(state)
    assert worker.requests == []  # still moving: the plain map, no check
    now[0] = 1.5 * PAUSE
    updates.update(state)
    assert len(worker.requests) == 1
    state.document.live = state.document.live.replace(target=strong_target())  # it moves again
    now[0] = 1.6 * PAUSE
    updates.update(state)
    assert len(worker.requests) == 1
    now[0] = 3.0 * PAUSE
    updates.update(state)
    assert len(worker.requests) == 2 and np.array_equal(worker.requests[1].target, strong_target())


def test_fold_free_needs_poisson_is_undoable_and_another_kernel_turns_it_off(starfish_basis):
    state = opened(starfish_basis)
    assert commands.COMMANDS["fold_free"].undoable
    commands.command(state, "fold_free")
    assert state.document.live.fold_free
    commands.command(state, "undo")
    assert not state.document.live.fold_free
    commands.command(state, "redo")
    commands.command(state, "kernel", "mean-value")
    assert state.document.live.kernel == "mean-value" and not state.document.live.fold_free
    assert status_check(state) == "no fold-free proof (poisson only)"
    commands.command(state, "fold_free")
    assert not state.document.live.fold_free
    assert "needs the poisson kernel" in state.status_message() and state.status.message_is_error
    # Without a basis for the mean-value kernel, no check is asked for.
    worker = StandInWorker()
    CheckUpdates(worker, print).update(state)
    assert worker.requests == []


def test_the_session_keeps_fold_free_as_warp_reads_it(starfish_basis):
    state = opened(starfish_basis)
    assert "fold_free" not in session_json(session_of(state, 12.0))  # absent, as older versions wrote
    commands.command(state, "fold_free")
    session = session_of(state, 12.0)
    assert session.fold_free is True and session_json(session)["fold_free"] is True
    undo, redo = history_of(session.history, ASSETS / "starfish.png")
    assert [step.fold_free for step in undo] == [False] and redo == []
    # Older sessions' steps (no key) read as before.
    steps = session_json(session)["history"]["undo"]
    del steps[0]["fold_free"]
    value = {**session_json(session), "image": "starfish.png", "history": {"undo": steps}}
    older = session_from_json(value, ASSETS / "s.json")
    assert history_of(older.history, ASSETS / "starfish.png")[0][0].fold_free is False


def test_the_worker_process_answers_the_newest_request(starfish_basis):
    import time

    from app.viewer.fold_free import CheckWorker

    older = make_check_request(STARFISH, STARFISH, False, starfish_basis)
    newest = make_check_request(STARFISH, strong_target(), True, starfish_basis)
    worker = CheckWorker()
    try:
        assert worker.poll() == []  # not started before the first request
        worker.submit(older)
        worker.submit(newest)
        messages, deadline = [], time.monotonic() + 120
        while newest.key not in [m.key for m in messages if isinstance(m, WarpCheck)]:
            assert time.monotonic() < deadline, "the worker did not answer within 120 s"
            messages += worker.poll()
            time.sleep(0.05)
        assert {m.key for m in messages} <= {older.key, newest.key}
        answers = [m for m in messages if isinstance(m, WarpCheck)]
        assert answers[-1].key == newest.key and answers[-1].injective
        assert answers[-1].positions.shape == starfish_basis.mesh.vertices.shape
        # On its way, the fold-free map said how much of the path it had proven.
        shares = [m.share for m in messages if isinstance(m, CheckProgress) and m.key == newest.key]
        assert shares and shares == sorted(shares) and shares[-1] == 1.0
    finally:
        worker.close()


def test_the_precompute_worker_forks_the_check_worker_and_ends_it(starfish_basis):
    """In the viewer the check worker is forked by the precompute worker (it loads nothing
    itself): it answers through its pipes, and it ends with the precompute worker, never left
    running without it."""
    import multiprocessing
    import time

    from app.viewer.fold_free import CheckWorker
    from app.viewer.precompute import Precompute

    worker = CheckWorker()
    precompute = Precompute(companion=worker.hosted())
    try:
        request = make_check_request(STARFISH, STARFISH, False, starfish_basis)
        worker.submit(request)
        answers, deadline = [], time.monotonic() + 120
        while not answers:
            assert time.monotonic() < deadline, "the hosted worker did not answer within 120 s"
            answers = [m for m in worker.poll() if isinstance(m, WarpCheck) and m.key == request.key]
            time.sleep(0.05)
        assert answers[0].injective
        (host,) = (p for p in multiprocessing.active_children() if p.name == "transfinite-precompute")
        children = Path(f"/proc/{host.pid}/task/{host.pid}/children").read_text().split()
        assert len(children) == 1  # the check worker, the precompute worker's child
    finally:
        worker.close()
        precompute.close()
    assert not precompute.alive and not Path(f"/proc/{children[0]}").exists()


def test_a_fold_free_map_is_abandoned_for_a_newer_request(starfish_basis, monkeypatch):
    """The worker drops a fold-free map (a strong drag's can take a minute) at its first step once
    the viewer has asked for a newer target, and answers that one instead."""
    import multiprocessing
    import threading

    from app.viewer import fold_free as module

    slow = make_check_request(STARFISH, strong_target(), True, starfish_basis)
    newer = make_check_request(STARFISH, STARFISH, False, starfish_basis)
    request_reader, request_writer = multiprocessing.Pipe(duplex=False)
    result_reader, result_writer = multiprocessing.Pipe(duplex=False)
    shares = []
    real = module.compute_check

    def compute_check(request, progress=None):
        def noted(share):
            shares.append((request.key, share))
            if len(shares) == 1:
                request_writer.send(newer)  # the viewer asks again while the map is being made
            progress(share)

        return real(request, noted)

    monkeypatch.setattr(module, "compute_check", compute_check)
    request_writer.send(slow)
    worker = threading.Thread(target=module._serve, args=(request_reader, result_writer, 0))
    worker.start()
    try:
        assert result_reader.poll(120), "no answer within 120 s"
        answer = result_reader.recv()
    finally:
        request_writer.send(module._Stop())
        worker.join(30)
    assert answer.key == newer.key and answer.injective
    assert [key for key, _ in shares] == [slow.key]  # abandoned at its first step
    assert not result_reader.poll(0.1)  # and nothing sent for it


def test_the_status_line_says_how_far_the_fold_free_map_has_come(starfish_basis):
    state = opened(starfish_basis, strong_target())
    state.document.live = state.document.live.replace(fold_free=True)
    worker = StandInWorker()
    updates = CheckUpdates(worker, print)
    updates.update(state)
    request = worker.requests[-1]
    assert status_check(state) == "computing the fold-free map..."
    worker.answers += [CheckProgress(request.key, 0.4), CheckProgress("an older target", 0.9)]
    updates.update(state)
    assert status_check(state) == "fold-free map: 40 % of the way"
    worker.answer(request)
    updates.update(state)
    assert state.compute.check_progress is None and status_check(state).startswith(
        "fold-free on the mesh, proven"
    )


def test_playing_keyframes_asks_for_no_check(starfish_basis):
    state = opened(starfish_basis)
    worker = StandInWorker()
    state.playback.playing = True
    CheckUpdates(worker, print).update(state)
    assert worker.requests == []
    state.playback.playing = False
    CheckUpdates(worker, print).update(state)
    assert len(worker.requests) == 1


def test_undo_and_redo_of_a_fold_free_step_reuse_its_proof(starfish_basis):
    state = opened(starfish_basis, target=strong_target())
    worker = StandInWorker()
    announced = []
    updates = CheckUpdates(worker, announced.append)
    updates.update(state)
    worker.answer(worker.requests[-1])
    updates.update(state)
    commands.command(state, "fold_free")  # B: one undo step, a new proof
    updates.update(state)
    worker.answer(worker.requests[-1])
    updates.update(state)
    proven = current_check(state)
    assert proven.fold_free and proven.injective and len(worker.requests) == 2
    commands.command(state, "undo")
    assert state.status_message() == "undone: fold-free on"
    updates.update(state)
    assert not current_check(state).fold_free and len(worker.requests) == 2  # the plain map's, kept
    commands.command(state, "redo")
    assert state.status_message() == "redone: fold-free on"
    updates.update(state)
    assert current_check(state) is proven and len(worker.requests) == 2 and not updates.pending
    assert announced[-1] == "check reused fold_free=True"


def test_nothing_is_said_to_be_checked_while_a_new_cage_is_drawn(starfish_basis):
    state = opened(starfish_basis)
    assert status_check(state) == "checking folds..."
    commands.command(state, "new_cage")
    assert state.selection.drawing is not None and status_check(state) == "fold-free: -"
    commands.command(state, "cancel")
    assert status_check(state) == "checking folds..."
