"""The viewer's injectivity check and fold-free map, computed in a background process.

For the live target of a ``poisson`` warp the worker computes either the certificate of the
plain map (`core.certify_injective`, ~0.2 s on the starfish demo) or, with the document's
"Fold-free" on, the certified fold-free map at the mesh's vertices (`core.fold_free_deform`,
~0.4 s at the default mesh, with its certificate): neither may block a frame.  While a handle
moves nothing is asked (the frames draw the plain map, or with "Fold-free" on positions proven
fold-free on the mesh: `app.viewer.fold_free_frames`); once the drag pauses (`PAUSE` seconds) or ends,
the newest target is sent, a newer request supersedes an older one, and a result is applied only
if its key is still the one the live document wants (`check_key`): a stale certificate is never
shown for a newer target.
"""

from __future__ import annotations

import hashlib
import multiprocessing
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from app.viewer.message_waker import MessageWaker
from app.viewer.parent_ends import keep_from_forks
from app.viewer.state import AppState, BasisResult, WarpCheck

#: Seconds a dragged handle must rest before the check of its target is asked for.
PAUSE = 0.3
#: The kernel whose maps are harmonic: the only one the certificate and the fold-free map support.
HARMONIC_KERNEL = "poisson"
#: Checks kept for their targets' return (undo, redo): each fold-free one holds the map at the vertices.
KEPT_CHECKS = 16


@dataclass(frozen=True)
class CheckRequest:
    """One check: the certificate of the map of `cage` onto `target`, and with `fold_free` the
    fold-free map at the mesh's vertices.

    Attributes
    ----------
    key : str
        `check_key` of the inputs.
    cage, target : ndarray of shape (n, 2)
    fold_free : bool
    vertices : ndarray of shape (V, 2)
    triangles : ndarray of shape (T, 3)
    boundary : ndarray of shape (B,), int
    boundary_parameters : ndarray of shape (B,)
    """

    key: str
    cage: np.ndarray
    target: np.ndarray
    fold_free: bool
    vertices: np.ndarray
    triangles: np.ndarray
    boundary: np.ndarray
    boundary_parameters: np.ndarray


@dataclass(frozen=True)
class CheckProgress:
    """The worker's word on a fold-free map being made: the share of the path proven so far."""

    key: str
    share: float


def check_key(cage: np.ndarray, target: np.ndarray, fold_free: bool, basis_key: str) -> str:
    """Identity of a check: the cage (n, 2), the target (n, 2), the fold-free switch and the mesh
    (the `BasisResult` key it was made with)."""
    digest = hashlib.sha256()
    for points in (cage, target):
        digest.update(np.ascontiguousarray(points, dtype=np.float64).tobytes())
    digest.update(f"{bool(fold_free)}:{basis_key}".encode())
    return digest.hexdigest()[:24]


def make_check_request(
    cage: np.ndarray, target: np.ndarray, fold_free: bool, basis: BasisResult
) -> CheckRequest:
    """The `CheckRequest` of a target on the mesh of `basis`."""
    mesh = basis.mesh
    return CheckRequest(
        check_key(cage, target, fold_free, basis.key),
        np.array(cage),
        np.array(target),
        bool(fold_free),
        mesh.vertices,
        mesh.triangles,
        mesh.boundary,
        mesh.boundary_parameters,
    )


def compute_check(request: CheckRequest, progress: Callable[[float], None] | None = None) -> WarpCheck:
    """The certificate (and with `request.fold_free` the fold-free positions (V, 2)), in this
    process: the worker's job, also used by tests.  A fold-free path that cannot be proven (a cage
    on the straight path crosses itself) gives a failed check with the reason.  `progress` goes to
    `core.fold_free_deform` (an exception it raises abandons the check)."""
    import core

    started = time.perf_counter()
    curve = core.ClosedBSpline(request.cage)
    positions = None
    try:
        if request.fold_free:
            positions, certificate = core.fold_free_deform(
                curve,
                request.target,
                request.vertices,
                boundary=(request.boundary, request.boundary_parameters),
                triangles=request.triangles,
                progress=progress,
            )
        else:
            certificate = core.certify_injective(curve, request.target)
    except ValueError as error:
        nowhere = np.zeros((0, 2))
        return WarpCheck(request.key, request.fold_free, False, 0.0, nowhere, nowhere, str(error), None, 0.0)
    where = np.asarray(certificate.where, dtype=np.float64).reshape(-1, 2)
    return WarpCheck(
        request.key,
        request.fold_free,
        bool(certificate.injective),
        float(certificate.sigma2_min),
        where,
        _images(curve, request.target, where) if not request.fold_free else where,
        str(certificate),
        positions,
        time.perf_counter() - started,
        bool(certificate.on_mesh),
    )


def _images(curve, target: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The plain map's images (K, 2) of source points (K, 2): G(points) P'; a point the kernel
    refuses (on or outside the curve, where a corner's proof fails) stays where it is."""
    import core

    try:
        return core.deform(core.basis_functions(curve, points), target)
    except ValueError:
        pass
    images = points.copy()
    for index, point in enumerate(points):
        try:
            images[index] = core.deform(core.basis_functions(curve, point[None]), target)[0]
        except ValueError:
            continue
    return images


def status_text(check: WarpCheck, folded: int | None) -> str:
    """The status line's words for a check: fold-free on the mesh (the mesh's map proven a bijection),
    proven fold-free with its σ₂ bound (the fold-free map:
    harmonic and proven outside the discs of its sharp corners, radial inside them, if it has
    some), or where the proof fails (`folded`: the mesh's folded triangles, to say whether it does
    fold there).  A fold-free map whose mesh still shows `folded` triangles says so: the map is a
    bijection, the mesh's straight edges are too coarse to follow it there."""
    if check.fold_free and check.positions is None:
        return f"fold-free map failed: {check.text}"
    if check.on_mesh and check.injective:  # the mesh's map is what is proven, its σ₂ per triangle
        return f"fold-free on the mesh, proven (σ₂ ≥ {check.sigma2_min:.2g})"
    if check.fold_free or check.injective:
        text = f"fold-free, proven (σ₂ ≥ {check.sigma2_min:.2g})"
        if not check.injective:  # a composite proven outside its corners' discs, radial inside
            text = f"fold-free, proven (σ₂ ≥ {check.sigma2_min:.2g} outside {len(check.where)} corner discs)"
        coarse = (
            f"; the mesh is too coarse for it in {folded} triangles" if check.fold_free and folded else ""
        )
        return text + coarse
    if not len(check.where):
        return check.text
    return "folds near the marked spots" if folded else "not proven fold-free near the marked spots"


class CheckWorker:
    """The process that computes checks, newest request first, and the main thread's pipes, at
    lowered priority (`nice`) so that the window's frames win the CPU.

    In the viewer the precompute worker forks it once it has loaded `core` (`hosted`,
    `app.viewer.precompute.Precompute`'s companion): ready in milliseconds, where a process of its
    own loads `core` again (~0.8 s of CPU).  Otherwise it starts with the first request.

    A request holds the mesh (~200 kB at the default mesh), more than a pipe buffers: a thread
    sends it, so that the window's frame never waits for the worker to finish the check it is on.
    """

    def __init__(self, nice: int = 10):
        self.nice = nice
        self._process = self._requests = self._results = None
        self._latest: CheckRequest | None = None  # the newest request not yet sent
        self._wanted = threading.Condition()
        self._wake: Callable[[], None] | None = None
        self._waker: MessageWaker | None = None
        self._sender: threading.Thread | None = None

    def wake_on_message(self, wake: Callable[[], None]) -> None:
        """Call `wake` from a thread whenever a check or its progress is waiting, once the worker
        runs, so that a sleeping UI loop draws it (`app.viewer.message_waker.MessageWaker`)."""
        self._wake = wake
        if self._results is not None:
            self._waker = MessageWaker(self._results, wake, "check-waker")

    def hosted(self) -> tuple | None:
        """(target, arguments) of this worker's process, for another process to fork (the
        precompute worker, which closes this process's copies of the ends it is given once it has
        started): its priority is the forking process's.  None off Linux (Windows does not fork,
        macOS not safely): the worker then starts with the first request."""
        if not sys.platform.startswith("linux"):
            return None
        request_reader, result_writer = self._pipes()
        return _serve, (request_reader, result_writer, 0)

    def _start(self) -> None:
        request_reader, result_writer = self._pipes()
        self._process = multiprocessing.get_context("spawn").Process(
            target=_serve,
            args=(request_reader, result_writer, self.nice),
            name="transfinite-check",
            daemon=True,
        )
        self._process.start()
        request_reader.close()
        result_writer.close()

    def _pipes(self) -> tuple:
        """Make the pipes (and start the waker); the worker's ends."""
        request_reader, self._requests = multiprocessing.Pipe(duplex=False)
        self._results, result_writer = multiprocessing.Pipe(duplex=False)
        keep_from_forks(self._requests, self._results)
        if self._wake is not None:
            self._waker = MessageWaker(self._results, self._wake, "check-waker")
        return request_reader, result_writer

    def _send(self) -> None:
        """The sender thread: the newest request to the worker, until `close` sends None."""
        while True:
            with self._wanted:
                while self._latest is None:
                    self._wanted.wait()
                request, self._latest = self._latest, None
            try:
                self._requests.send(request)
            except OSError:
                return
            if isinstance(request, _Stop):
                return

    def submit(self, request: CheckRequest) -> None:
        """Ask for `request`, superseding any request not sent yet; never waits for the worker."""
        if self._requests is None:
            self._start()
        self._hand_over(request)

    def _hand_over(self, message) -> None:
        """Make `message` the next the sender thread sends.  The thread starts with the first
        message: the viewer forks its precompute worker before, from a process of one thread."""
        if self._sender is None:
            self._sender = threading.Thread(target=self._send, name="check-sender", daemon=True)
            self._sender.start()
        with self._wanted:
            self._latest = message
            self._wanted.notify()

    def poll(self) -> list[WarpCheck | CheckProgress]:
        """Checks and progress that arrived, without waiting."""
        if self._results is None:
            return []
        if self._waker is not None:
            self._waker.read()
        checks = []
        try:
            while self._results.poll():
                checks.append(self._results.recv())
        except (EOFError, OSError):
            pass
        return checks

    def close(self) -> None:
        """Stop the worker: it reads `_Stop`, or the end of its pipe (a hosted worker's host also
        ends it as it ends)."""
        if self._requests is None:
            return
        if self._waker is not None:
            self._waker.close()
        self._hand_over(_Stop())
        if self._process is not None:
            self._process.join(timeout=2.0)
            if self._process.is_alive():
                self._process.terminate()
                self._process.join(timeout=2.0)
        self._sender.join(timeout=2.0)
        if not self._sender.is_alive():  # closed under a send, its descriptor could be reused
            self._requests.close()
        self._results.close()


class _Stop:
    """The last message to the worker: stop."""


class _Superseded(Exception):
    """A newer request arrived while a fold-free map was being made."""


def _serve(requests, results, nice: int) -> None:
    """The worker: answer the newest request, drop a result whose request was superseded meanwhile;
    a fold-free map is abandoned at its next step once a newer request waits."""
    import os

    from app.viewer.precompute import freeze_after_loading

    if nice and hasattr(os, "nice"):
        try:
            os.nice(nice)
        except OSError:
            pass
    freeze_after_loading("core")

    def abandon_if_superseded(share: float) -> None:
        if requests.poll():  # a fold-free map of a strong drag can take a minute: not for a stale target
            raise _Superseded
        results.send(CheckProgress(request.key, share))

    try:
        request = requests.recv()
        while not isinstance(request, _Stop):
            while requests.poll():
                request = requests.recv()
            if isinstance(request, _Stop):
                return
            try:
                check = compute_check(request, abandon_if_superseded)
            except _Superseded:
                request = requests.recv()  # the newer request that abandoned it
                continue
            if requests.poll():
                request = requests.recv()
                continue
            results.send(check)
            request = requests.recv()
    except (EOFError, BrokenPipeError, ConnectionResetError):
        return


class CheckUpdates:
    """Keeps `AppState.compute.check` the check of the live document, asked of a worker.

    Parameters
    ----------
    worker : CheckWorker (or anything with ``submit`` and ``poll``)
    announce : callable
        Called with one line per check applied (the window tests read them).
    clock : callable
        Seconds, for the drag's pause (`time.perf_counter`).
    """

    def __init__(
        self, worker, announce: Callable[[str], None], clock: Callable[[], float] = time.perf_counter
    ):
        self.worker, self.announce, self.clock = worker, announce, clock
        self.submitted: str | None = None
        self._moved: tuple[bytes, float] | None = None  # (the dragged target, when it last changed)
        # The last checks made, by key: undo and redo come back to them without a new proof.
        self.made: dict[str, WarpCheck] = {}

    def wanted(self, state: AppState) -> CheckRequest | None:
        """The check the live document needs now, None when there is none to ask for (another
        kernel, no basis for this cage yet, a handle moving, keyframes playing)."""
        live, basis = state.document.live, state.compute.basis
        if live.kernel != HARMONIC_KERNEL or live.n < 3 or state.selection.drawing is not None:
            return None
        if state.playback.playing:
            return None  # a new target every frame: checked once playback stops
        if basis is None or basis.kernel != HARMONIC_KERNEL or not np.array_equal(basis.cage, live.cage):
            return None
        if state.selection.drag is not None:
            key, now = live.target.tobytes(), self.clock()
            if self._moved is None or self._moved[0] != key:
                self._moved = (key, now)
            if state.selection.drag.kind != "target" or now - self._moved[1] < PAUSE:
                return None
        return make_check_request(live.cage, live.target, live.fold_free, basis)

    def update(self, state: AppState) -> None:
        """Apply the checks that arrived for the live document; ask for its check if not asked yet."""
        request = self.wanted(state)
        key = None if request is None else request.key
        for check in self.worker.poll():
            if isinstance(check, CheckProgress):
                if check.key == key:  # of an older target: dropped, as its check would be
                    state.compute.check_progress = check.share
            else:
                self.made[check.key] = check
                if len(self.made) > KEPT_CHECKS:
                    del self.made[next(iter(self.made))]  # the oldest
                if check.key == key:
                    state.compute.check, state.compute.check_progress = check, None
                    self.announce(
                        f"check fold_free={check.fold_free} injective={check.injective} "
                        f"where={len(check.where)} seconds={check.seconds:.3f}"
                    )
        if key in self.made and (state.compute.check is None or state.compute.check.key != key):
            state.compute.check, state.compute.check_progress = self.made[key], None  # an undo or a redo
            self.announce(f"check reused fold_free={self.made[key].fold_free}")
        check = state.compute.check
        done = check is not None and check.key == key
        if done or request is None:
            self.submitted = None if done else self.submitted
            return
        if key != self.submitted:
            self.worker.submit(request)
            self.submitted, state.compute.check_progress = key, None

    @property
    def pending(self) -> bool:
        """A check was asked for and has not been applied (its result wakes the loop:
        `CheckWorker.wake_on_message`)."""
        return self.submitted is not None


def current_check(state: AppState) -> WarpCheck | None:
    """The check of the live document as it is (never one of an older target), or None."""
    live, basis, check = state.document.live, state.compute.basis, state.compute.check
    if check is None or basis is None or live.kernel != HARMONIC_KERNEL:
        return None
    if check.key != check_key(live.cage, live.target, live.fold_free, basis.key):
        return None
    return check
