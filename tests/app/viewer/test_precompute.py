"""The basis-function precompute in its background process (app.viewer.precompute)."""

import time
from pathlib import Path

import numpy as np
import pytest

import core
from app.viewer.precompute import Precompute, basis_key, compute, make_request
from app.viewer.state import Snapshot
from core.curves import examples

STAR = examples.starfish(points_per_arm=2) * np.array([100.0, -100.0]) + 200.0


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("TRANSFINITE_CACHE_DIR", str(tmp_path))


def snapshot(**changes):
    return Snapshot(Path("x.png"), STAR, STAR, **changes)


def test_keys_follow_what_the_basis_depends_on():
    base = basis_key(snapshot(), 5.0)
    assert base == basis_key(snapshot().replace(target=STAR + 9), 5.0)  # not the target
    others = {
        basis_key(snapshot(kernel="mean-value"), 5.0),
        basis_key(snapshot(), 4.0),
        basis_key(snapshot().replace(cage=STAR + 1), 5.0),
        basis_key(snapshot(kernel="power", power=3.0), 5.0),
        basis_key(snapshot(kernel="power", power=3.0, shift="none"), 5.0),
    }
    assert base not in others and len(others) == 5
    assert basis_key(snapshot(power=3.0), 5.0) == base  # ignored by other kernels


def test_compute_meshes_and_interpolates(cache):
    progress = []
    payload = compute(make_request(snapshot(), 8.0), lambda fraction, phase: progress.append(phase))
    basis, vertices = payload["basis"], payload["vertices"]
    np.testing.assert_allclose(basis.sum(axis=1), 1.0, atol=1e-10)
    np.testing.assert_allclose(basis @ STAR, vertices, atol=1e-5)  # linear precision
    assert progress[0] == "meshing" and "basis functions" in progress


def test_the_distortion_view_gets_gradients_for_point_kernels_only(cache):
    from app.viewer.precompute import GRADIENTS_PHASE

    point = snapshot(kernel="inverse-cube-mean")
    wanted = make_request(point, 8.0, gradients=True)
    assert wanted.gradients and wanted.key != make_request(point, 8.0).key
    progress = []
    payload = compute(wanted, lambda fraction, phase: progress.append(phase))
    gradients, vertices = payload["gradients"], payload["vertices"]
    assert gradients.shape == (len(vertices), len(STAR), 2)
    interior = np.isfinite(gradients).all(axis=(1, 2))
    assert 0.5 * len(vertices) < interior.sum() < len(vertices)  # NaN rows on the boundary only
    identity = np.einsum("id,mie->mde", STAR, gradients[interior])  # linear precision, differentiated
    np.testing.assert_allclose(identity, np.broadcast_to(np.eye(2), identity.shape), rtol=0, atol=1e-6)
    assert progress.index(GRADIENTS_PHASE) > progress.index("basis functions")
    # FEM harmonic and the arc-length parameterisation have no pointwise gradients: not asked for.
    for other in (snapshot(kernel="harmonic"), point.replace(parameterization="arc-length")):
        request = make_request(other, 8.0, gradients=True)
        assert not request.gradients and request.key == make_request(other, 8.0).key


def test_the_worker_process_computes_supersedes_and_reports_errors(cache):
    precompute = Precompute()
    try:
        first = make_request(snapshot(), 4.0)
        second = make_request(snapshot(kernel="mean-value"), 6.0)
        precompute.submit(first)
        precompute.submit(second)  # supersedes the first
        assert precompute.pending == second.key
        messages = _until(precompute, lambda m: m[0] in ("done", "error"))
        done = [m for m in messages if m[0] == "done"]
        assert [m[1] for m in done] == [second.key]
        result = done[0][2]
        assert result.kernel == "mean-value" and result.basis.shape == (len(result.mesh.vertices), len(STAR))
        assert result.columns.flags.f_contiguous and result.columns.dtype == np.float32
        np.testing.assert_array_equal(result.cage, STAR)
        assert precompute.pending is None and precompute.remembered(second.key) is result
        # A kernel that does not take this domain: an error message, the worker lives on.
        bad = make_request(snapshot(kernel="wachspress"), 6.0)
        precompute.submit(bad)
        messages = _until(precompute, lambda m: m[0] in ("done", "error"))
        assert messages[-1][:2] == ("error", bad.key) and "convex" in messages[-1][2]
        assert precompute.alive
    finally:
        precompute.close()
    assert not precompute.alive


def test_memory_keeps_the_last_results():
    from app.viewer import precompute as module

    holder = Precompute.__new__(Precompute)
    holder._memory = module.OrderedDict()
    for number in range(module.MEMORY_RESULTS + 2):
        holder.remember(type("R", (), {"key": str(number)})())
    assert holder.remembered("0") is None and holder.remembered(str(module.MEMORY_RESULTS + 1)) is not None


def _until(precompute, stop, timeout=90.0):
    messages, deadline = [], time.monotonic() + timeout
    while time.monotonic() < deadline:
        batch = precompute.poll()
        messages.extend(batch)
        if any(stop(m) for m in batch):
            return messages
        time.sleep(0.02)
    raise AssertionError(f"no result within {timeout} s: {messages[-3:]}")


def test_meshes_from_the_worker_are_core_meshes(cache):
    payload = compute(make_request(snapshot(), 10.0))
    mesh = core.Mesh(
        payload["vertices"], payload["triangles"], payload["boundary"], payload["boundary_parameters"]
    )
    assert not core.folded_triangles(mesh, payload["basis"] @ STAR).any()


def test_the_worker_ends_quietly_when_the_viewer_is_gone(cache):
    """A viewer killed with kill -9 closes its ends of the pipes: the worker must end, without a
    traceback, both while waiting for a request and in the middle of one."""
    import multiprocessing

    from app.viewer.precompute import _serve

    request_reader, request_writer = multiprocessing.Pipe(duplex=False)
    result_reader, result_writer = multiprocessing.Pipe(duplex=False)
    request_writer.close()  # waiting for a request: EOF
    _serve(request_reader, result_writer, 0)

    request_reader, request_writer = multiprocessing.Pipe(duplex=False)
    result_reader, result_writer = multiprocessing.Pipe(duplex=False)
    request_writer.send(make_request(Snapshot(Path("x.png"), STAR, STAR), 20.0))
    request_writer.close()
    result_reader.close()  # nobody reads the progress or the result: a broken pipe
    _serve(request_reader, result_writer, 0)


def test_a_dense_mesh_gets_a_preview_mesh_that_draws_its_interpolant(cache, monkeypatch):
    """Above PREVIEW_FROM_VERTICES vertices the result carries a coarser mesh and G moved onto it
    (core.meshes.mesh_transfer); below, none.  Thresholds lowered so that a small mesh shows both."""
    from app.viewer import precompute as module
    from app.viewer.precompute import PREVIEW_PHASE, result_from_message
    from core.meshes.mesh_transfer import interpolation_matrix

    request = make_request(snapshot(), 3.0)
    assert compute(request)["preview"] is None  # a few thousand vertices: no preview
    monkeypatch.setattr(module, "PREVIEW_FROM_VERTICES", 1000)
    monkeypatch.setattr(module, "PREVIEW_VERTICES", 400)
    progress = []
    payload = compute(request, lambda fraction, phase: progress.append(phase))
    assert progress[-1] == PREVIEW_PHASE
    result = result_from_message(request.key, payload)
    preview = result.preview
    assert len(result.mesh.vertices) > 1000 and 250 < len(preview.vertices) < 650
    assert preview.basis.shape == (len(preview.vertices), len(STAR))
    np.testing.assert_allclose(preview.basis.sum(axis=1), 1.0, atol=1e-10)
    np.testing.assert_allclose(preview.basis @ STAR, preview.vertices, atol=1e-5)
    # Away from the boundary a preview vertex moves exactly as the dense mesh's P1 interpolant.
    curve = core.ClosedBSpline(STAR)
    coarse = core.triangulate(curve, max_edge=3.0 * np.sqrt(len(result.mesh.vertices) / 400))
    assert np.array_equal(coarse.vertices, preview.vertices)
    interior = np.setdiff1d(np.arange(len(coarse.vertices)), coarse.boundary)
    target = STAR + np.random.default_rng(4).normal(0.0, 5.0, STAR.shape)
    expected = interpolation_matrix(result.mesh, coarse.vertices[interior]) @ (result.basis @ target)
    np.testing.assert_allclose((preview.basis @ target)[interior], expected, atol=1e-9)


def test_a_forked_child_closes_the_ends_kept_from_forks():
    # A worker forked from the viewer must not hold the viewer's end of its request pipe, or it
    # never sees the viewer gone (app.viewer.parent_ends).
    import multiprocessing
    import os

    from app.viewer.parent_ends import keep_from_forks

    reader, writer = multiprocessing.Pipe(duplex=False)
    keep_from_forks(writer)
    child = os.fork()
    if child == 0:
        os._exit(0 if writer.closed else 1)
    _, status = os.waitpid(child, 0)
    assert os.waitstatus_to_exitcode(status) == 0
    assert not writer.closed  # this process's own stays open
    writer.send("still here")
    assert reader.recv() == "still here"


def test_workers_are_forked_only_from_a_process_of_one_thread():
    # A thread pool's idle threads are not forked: a task queued to it in the child never runs.
    import sys
    import threading

    from app.viewer.precompute import start_method

    release = threading.Event()
    waiting = threading.Thread(target=release.wait)
    waiting.start()
    try:
        assert start_method() == "spawn"
    finally:
        release.set()
        waiting.join()
    if threading.active_count() == 1 and sys.platform.startswith("linux"):  # not under xdist's threads
        parallel = sys.modules.get("numba.np.ufunc.parallel")
        assert start_method() == ("spawn" if parallel and parallel._is_initialized else "fork")
