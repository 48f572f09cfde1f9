"""The basis-function precompute (Sec. 4.3) in a background process, with progress and cancellation.

Meshing the cage and computing G (V x n) take seconds, and on the very first run
numba compiles the solver first (tens of seconds, its own progress phase, see
`core.newton.compilation`).  Compiling holds the GIL, so in a thread it would stall the
viewer's frames; a separate process at lowered priority keeps the UI responsive and still gets
the otherwise idle cores.  On Linux it is forked from the viewer before the window opens
(`start_method`), with what the viewer has loaded already (~0.6 s of CPU less than loading `core`
again, and the first basis as much sooner); elsewhere it starts with ``spawn``.  Once it has
loaded `core` it forks the fold-free check's worker (`app.viewer.fold_free`), which so loads
nothing itself.
The protocol is two pipes:

- requests go to the worker; a newer request supersedes (cancels) the one running,
  checked whenever the kernel reports progress;
- ``("progress", key, fraction, phase)``, ``("done", key, result)`` and
  ``("error", key, message)`` come back and are read on the main thread by
  `Precompute.poll`, which never blocks.

The main thread applies a result only if its key is still the one it wants
(a stale result, for a cage edited meanwhile, is discarded), and keeps the last
few in memory so that undo and redo of a cage edit redraw at once.  G itself is
also kept on disk by `core.mesh_basis_functions`.
"""

from __future__ import annotations

import hashlib
import json
import multiprocessing
import multiprocessing.connection
import os
import signal
import sys
import threading
import time
import traceback
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from app.viewer.message_waker import MessageWaker
from app.viewer.parent_ends import keep_from_forks
from app.viewer.state import BasisResult, PreviewMesh, Snapshot

#: Results kept in memory for undo and redo.
MEMORY_RESULTS = 6
#: Seconds between two progress messages of the worker.
PROGRESS_INTERVAL = 0.05
#: The phase shown while grad G is computed for the distortion view.
GRADIENTS_PHASE = "gradients of the basis functions (the first time: compiling, ~15 s)"
#: Vertices of the preview mesh drawn while a handle of a dense mesh moves (`PreviewMesh`):
#: llvmpipe at 1280x1024 draws it in ~25 ms, where 400k vertices take ~170-280 ms.
PREVIEW_VERTICES = 20_000
#: Meshes with at least this many vertices get a preview mesh.
PREVIEW_FROM_VERTICES = 50_000
#: The phase shown while the preview mesh is made.
PREVIEW_PHASE = "a lighter mesh for dragging"
#: Priority decrease of the background compilation (`Precompute` with warm_up): below the worker's.
WARM_UP_NICE = 15


@dataclass(frozen=True)
class Request:
    """One precompute: the mesh of the cage and G for a kernel.

    Attributes
    ----------
    key : str
        `basis_key` of the inputs below.
    cage : ndarray of shape (n, 2)
    kernel : str
    params : dict
        Keyword arguments of `core.mesh_basis_functions` (``power``, ``shift``,
        ``parameterization``; `Snapshot.basis_params`).
    max_edge : float
        Mesh edge length, image pixels.
    gradients : bool
        Also grad G at the vertices (the distortion view; point kernels only).
    """

    key: str
    cage: np.ndarray
    kernel: str
    params: dict
    max_edge: float
    gradients: bool = False


def has_gradients(kernel: str, parameterization: str = "natural") -> bool:
    """Whether `kernel` has pointwise gradients (`core.mesh_basis_functions(gradients=True)`):
    the point kernels (Cauchy–Green's complex ones included), with the natural parameterisation."""
    import core

    return kernel in (*core.KERNELS, *core.COMPLEX_KERNELS) and parameterization == "natural"


def basis_key(snapshot: Snapshot, max_edge: float, gradients: bool = False) -> str:
    """Identity of the basis functions a snapshot needs: its cage, kernel, parameters and mesh size
    (and whether their gradients are wanted too)."""
    digest = hashlib.sha256()
    digest.update(np.ascontiguousarray(snapshot.cage, dtype=np.float64).tobytes())
    settings = {"kernel": snapshot.kernel, "params": snapshot.basis_params(), "max_edge": float(max_edge)}
    if gradients:
        settings["gradients"] = True
    digest.update(json.dumps(settings, sort_keys=True).encode())
    return digest.hexdigest()[:24]


def make_request(snapshot: Snapshot, max_edge: float, gradients: bool = False) -> Request:
    """The `Request` for a snapshot's basis functions (with their gradients if `gradients` and
    the kernel has them)."""
    gradients = gradients and has_gradients(snapshot.kernel, snapshot.parameterization)
    return Request(
        basis_key(snapshot, max_edge, gradients),
        np.array(snapshot.cage),
        snapshot.kernel,
        snapshot.basis_params(),
        float(max_edge),
        gradients,
    )


def result_from_message(key: str, payload: dict) -> BasisResult:
    """Build a `BasisResult` from the worker's ``done`` payload."""
    import core

    basis = np.asarray(payload["basis"])
    basis = basis.astype(np.complex128 if np.iscomplexobj(basis) else np.float64, copy=False)
    mesh = core.Mesh(
        payload["vertices"], payload["triangles"], payload["boundary"], payload["boundary_parameters"]
    )
    preview = payload.get("preview")
    return BasisResult(
        key=key,
        cage=payload["cage"],
        mesh=mesh,
        basis=basis,
        columns=np.asfortranarray(basis.real, dtype=np.float32),
        imaginary_columns=np.asfortranarray(basis.imag, dtype=np.float32) if np.iscomplexobj(basis) else None,
        kernel=payload["kernel"],
        seconds=payload["seconds"],
        gradients=payload.get("gradients"),
        preview=None if preview is None else PreviewMesh(*preview),
    )


def compute(request: Request, progress=None) -> dict:
    """Mesh the cage and compute G, in this process: the worker's job (also used by tests).

    Returns
    -------
    dict
        ``cage`` (n, 2), the mesh's ``vertices`` (V, 2), ``triangles`` (T, 3),
        ``boundary`` and ``boundary_parameters``, ``basis`` (V, n), ``kernel``, ``seconds``,
        ``gradients`` ((V, n, 2), or None unless the request asked for them), ``preview``
        (None, or for `PREVIEW_FROM_VERTICES` vertices or more the `PreviewMesh` fields
        vertices, triangles and basis as a tuple).

    Raises
    ------
    ValueError
        The cage, kernel or parameters are invalid (message for the status line).
    """
    import core
    from app.warp.pipeline import WarpSettings, prepare
    from core import COMPILE_MESSAGE as COMPILING

    started = time.perf_counter()
    curve = core.ClosedBSpline(request.cage)

    def meshing(fraction: float) -> None:
        if progress is not None:
            progress(fraction, "meshing")

    meshing(0.0)
    superseded = []

    def compiling(fraction: float) -> None:
        # A newer request does not interrupt the first run's compilation (it needs
        # the same code): it is noted, and this request given up once compiled.
        if progress is not None and not superseded:
            try:
                progress(fraction, COMPILING)
            except _Superseded:
                superseded.append(True)

    def report(fraction: float) -> None:
        if superseded:
            raise _Superseded
        if progress is not None:
            progress(fraction, "basis functions")

    settings = WarpSettings(request.kernel, request.params, request.max_edge)
    warped = prepare(curve, settings, progress=report, compiling=compiling, meshing=meshing)
    mesh, basis = warped.mesh, warped.basis
    gradients = None
    if request.gradients:
        # G is in the disk cache now; grad G has no progress of its own, and its first use
        # compiles the gradient solver: the phase says so rather than sitting at an unexplained 0 %.
        if superseded:
            raise _Superseded
        if progress is not None:
            progress(0.0, GRADIENTS_PHASE)
        _, gradients = core.mesh_basis_functions(
            curve, mesh, kernel=request.kernel, gradients=True, **request.params
        )
    preview = None
    if len(mesh.vertices) >= PREVIEW_FROM_VERTICES:
        if superseded:
            raise _Superseded
        if progress is not None:
            progress(0.0, PREVIEW_PHASE)
        preview = _preview(curve, mesh, basis, request.max_edge, request.kernel)
    return {
        "cage": np.array(request.cage),
        "vertices": mesh.vertices,
        "triangles": mesh.triangles,
        "boundary": mesh.boundary,
        "boundary_parameters": mesh.boundary_parameters,
        "basis": basis,
        "kernel": request.kernel,
        "seconds": time.perf_counter() - started,
        "gradients": gradients,
        "preview": preview,
    }


def _preview(curve, mesh, basis: np.ndarray, max_edge: float, kernel: str) -> tuple:
    """(vertices, triangles, basis, boundary) of a mesh of about `PREVIEW_VERTICES` vertices of the
    same curve, whose rows of G draw what the dense mesh draws at its vertices
    (`core.meshes.mesh_transfer`).

    The complex coordinates (no Lagrange property, so their boundary rows are not the
    B-spline basis that `transfer_basis` puts there) are evaluated at the preview's vertices.
    """
    import core
    from core import transfer_basis

    coarse = core.triangulate(curve, max_edge=max_edge * np.sqrt(len(mesh.vertices) / PREVIEW_VERTICES))
    if np.iscomplexobj(basis):
        return (
            coarse.vertices,
            coarse.triangles,
            core.mesh_basis_functions(curve, coarse, kernel),
            coarse.boundary,
        )
    return coarse.vertices, coarse.triangles, transfer_basis(curve, mesh, basis, coarse), coarse.boundary


class Precompute:
    """The worker process and the main thread's side of its pipes.

    Parameters
    ----------
    nice : int
        Priority decrease of the worker (Unix), so that the UI wins the CPU.
    warm_up : bool
        Also compile the Newton solver and its gradients in a third process at
        `WARM_UP_NICE` (`core.compile_solver`, into numba's disk cache), while the
        default kernel (poisson, not compiled) is on screen: the first switch to a
        Newton kernel then loads it instead of compiling for ~15 s.  Once cached,
        it only loads and ends.
    companion : (callable, tuple), optional
        A process the worker forks once it has loaded `core` (target and arguments:
        `app.viewer.fold_free.CheckWorker.hosted`), so that it does not load `core` again; the
        worker ends it as it ends.  The arguments' pipe ends are closed here once the worker has
        its own.
    """

    def __init__(self, nice: int = 10, warm_up: bool = False, companion: tuple | None = None):
        context = multiprocessing.get_context(start_method())
        self._warm_up = None
        if warm_up:
            self._warm_up = context.Process(
                target=_compile_in_background, args=(WARM_UP_NICE,), name="transfinite-compile", daemon=True
            )
            self._warm_up.start()
        # Pipe(duplex=False) returns (receiving end, sending end).
        request_reader, self._requests = context.Pipe(duplex=False)
        self._results, result_writer = context.Pipe(duplex=False)
        keep_from_forks(self._requests, self._results)
        self._process = context.Process(
            target=_serve,
            args=(request_reader, result_writer, nice, companion),
            name="transfinite-precompute",
            daemon=True,
        )
        self._process.start()
        request_reader.close()
        result_writer.close()
        for argument in () if companion is None else companion[1]:
            if isinstance(argument, multiprocessing.connection.Connection):
                argument.close()
        self.pending: str | None = None  # key of the request running or queued
        self._memory: OrderedDict[str, BasisResult] = OrderedDict()
        self._waker: MessageWaker | None = None

    def wake_on_message(self, wake: Callable[[], None]) -> None:
        """Call `wake` from a thread whenever a message is waiting, so that a sleeping UI loop
        redraws (`app.viewer.message_waker.MessageWaker`; `poll` reads the messages)."""
        self._waker = MessageWaker(self._results, wake, "precompute-waker")

    def submit(self, request: Request) -> None:
        """Start computing `request`, superseding whatever runs."""
        self.pending = request.key
        self._requests.send(request)

    def remembered(self, key: str) -> BasisResult | None:
        """A result computed earlier in this session, if kept."""
        result = self._memory.get(key)
        if result is not None:
            self._memory.move_to_end(key)
        return result

    def remember(self, result: BasisResult) -> None:
        self._memory[result.key] = result
        self._memory.move_to_end(result.key)
        while len(self._memory) > MEMORY_RESULTS:
            self._memory.popitem(last=False)

    def poll(self) -> list[tuple]:
        """Messages that arrived, without waiting: progress, done (as `BasisResult`) and error."""
        messages = []
        if self._waker is not None:
            self._waker.read()
        try:
            while self._results.poll():
                message = self._results.recv()
                kind, key = message[0], message[1]
                if kind == "done":
                    result = result_from_message(key, message[2])
                    self.remember(result)
                    message = ("done", key, result)
                if kind in ("done", "error") and key == self.pending:
                    self.pending = None
                messages.append(message)
        except (EOFError, OSError):
            if self.pending is not None:
                messages.append(("error", self.pending, "the precompute process stopped unexpectedly"))
                self.pending = None
        return messages

    @property
    def alive(self) -> bool:
        return self._process.is_alive()

    def close(self) -> None:
        """Stop the worker (it abandons a running request at its next progress report)."""
        if self._waker is not None:
            self._waker.close()
        try:
            self._requests.send(None)
        except OSError:
            pass
        self._process.join(timeout=2.0)
        if self._process.is_alive():
            self._process.terminate()
            self._process.join(timeout=2.0)
        if self._warm_up is not None and self._warm_up.is_alive():
            self._warm_up.terminate()  # numba writes each cache file whole (a rename): none is left half
            self._warm_up.join(timeout=2.0)
        self._requests.close()
        self._results.close()


def start_method() -> str:
    """How the workers start: ``fork`` on Linux while this process runs one thread and numba's
    thread pool has not started, else ``spawn``.

    A forked worker has what this process loaded (`core`, numpy, numba: ~0.6 s of CPU to load).
    It must be forked before the window opens (it would hold the X connection), from one thread
    and before any parallel loop: other threads are not forked, and whatever waits for them in the
    child waits for ever (an idle thread pool's queue, as `core.kernels` solves in; GNU OpenMP,
    numba's threading layer where TBB is not installed, at the child's first parallel loop).
    Session locks are closed in the child (`app.viewer.session_lock`).  macOS does not fork
    safely, Windows not at all.
    """
    if not sys.platform.startswith("linux") or threading.active_count() > 1:
        return "spawn"
    parallel = sys.modules.get("numba.np.ufunc.parallel")
    if parallel is not None and getattr(parallel, "_is_initialized", True):
        return "spawn"
    return "fork"


class _Superseded(Exception):
    """A newer request arrived while one was running."""


def _lower_priority(nice: int) -> None:
    """Add `nice` to this process's niceness where the system allows it."""
    if nice and hasattr(os, "nice"):
        try:
            os.nice(nice)
        except OSError:
            pass


def freeze_after_loading(*modules: str) -> None:
    """Load `modules` (what a worker computes with), then keep everything loaded out of the
    garbage collector's full passes for good (`gc.freeze`): it lives as long as the process, and
    the collections at its exit no longer walk it (~0.2-0.3 s of CPU a worker)."""
    import gc
    import importlib

    for name in modules:
        importlib.import_module(name)
    gc.freeze()


def _compile_in_background(nice: int) -> None:
    """The warm-up process: compile (or load) the solver and its gradients, then end."""
    _lower_priority(nice)
    try:
        import core

        core.compile_solver(gradients=True)
    except Exception:  # noqa: BLE001 - only a head start: the worker compiles what it needs itself
        pass


def _serve(requests, results, nice: int, companion: tuple | None = None) -> None:
    """The worker process: fork the `companion` once `core` is loaded, then compute requests one
    at a time, newest first, until told to stop or until the viewer is gone (closed, or killed:
    its ends of the pipes are closed); then end the companion."""
    _lower_priority(nice)
    freeze_after_loading("core", "app.warp.pipeline")
    # Forked here, not in the window's process: this one holds no GL context, X connection,
    # session lock or thread of its own, and has loaded core.
    companion_pid = None if companion is None else _fork(*companion, unneeded=(requests, results))
    try:
        _serve_requests(requests, results)
    except (EOFError, BrokenPipeError, ConnectionResetError):
        return  # nobody left to answer: end quietly, not with a traceback
    finally:
        if companion_pid is not None:
            os.kill(companion_pid, signal.SIGTERM)
            os.waitpid(companion_pid, 0)


def _fork(target: Callable, arguments: tuple, unneeded: tuple = ()) -> int:
    """Run ``target(*arguments)`` in a child forked from this process; returns its pid.  This
    process's copies of the pipe ends among `arguments` are closed, and the child's of the
    connections `unneeded` (this process's own: their other ends see them closed when this
    process ends, whatever the child does)."""
    pid = os.fork()
    if pid == 0:
        code = 1
        try:
            for connection in unneeded:
                connection.close()
            target(*arguments)
            code = 0
        except BaseException:  # noqa: BLE001 - shown, as multiprocessing shows a worker's
            traceback.print_exc()
        finally:
            sys.stderr.flush()
            os._exit(code)
    for argument in arguments:
        if isinstance(argument, multiprocessing.connection.Connection):
            argument.close()
    return pid


def _serve_requests(requests, results) -> None:
    from core import load_compiled_integrals as load_compiled

    waiting = []
    compiled_layer = False
    while True:
        request = waiting.pop() if waiting else requests.recv()
        while requests.poll():  # only the newest request matters
            request = requests.recv()
        if request is None:
            return
        if request.gradients and not compiled_layer:
            # grad G takes the default kernel's compiled loops (numba's cache read once, ~0.25 s of
            # CPU, never compiling): 0.17 s instead of 0.23 s at the default mesh.  A basis alone
            # gains nothing measurable there, and core reads the cache by itself once a process
            # has evaluated enough points (`core.boundary_integrals.compiled_integrals`).
            compiled_layer = True
            try:
                load_compiled()
            except Exception:  # noqa: BLE001 - only a speed-up: the numpy path stays correct
                pass
        last = [0.0]

        def progress(fraction: float, phase: str, request=request, last=last) -> None:
            if requests.poll():
                waiting.append(requests.recv())
                raise _Superseded
            now = time.perf_counter()
            if now - last[0] >= PROGRESS_INTERVAL or fraction >= 1.0:
                last[0] = now
                results.send(("progress", request.key, float(fraction), phase))

        try:
            payload = compute(request, progress)
        except _Superseded:
            continue
        except ValueError as error:
            results.send(("error", request.key, str(error)))
            continue
        except Exception as error:  # noqa: BLE001 - reported in the status line, the worker lives on
            results.send(("error", request.key, f"{type(error).__name__}: {error}"))
            continue
        if requests.poll():
            waiting.append(requests.recv())
            continue
        results.send(("done", request.key, payload))
