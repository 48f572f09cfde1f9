"""What the commands say on the console: exit codes, one-line notes and errors, a progress bar.

The command line's conventions (.docs/architecture.md, "Files and conventions"): exit code 0
on success, 1 when the environment cannot run the command (no OpenGL), 2 for bad
input.  A failing command prints exactly one line on stderr, its error; the notes
and warnings of a command are held back with `note` and printed by `print_notes`
once it has succeeded.
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
import threading
import time
from collections.abc import Iterator

EXIT_OK = 0
EXIT_ENVIRONMENT = 1
EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130
#: The reader of standard output went away (``| head``): what a process killed by SIGPIPE reports.
EXIT_BROKEN_PIPE = 141

# Notes and warnings of the running command, printed on stderr once it succeeds:
# when it fails, its error stays the only line.
_pending_notes: list[str] = []


def note(message: str) -> None:
    """Report `message` (one line) on stderr when the command has succeeded."""
    _pending_notes.append(_one_line(message))


def note_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A `warnings.showwarning` that turns each warning into a `note`."""
    note(f"warning: {message}")


def print_notes() -> None:
    """Print the notes held back so far on stderr, and forget them."""
    for message in _pending_notes:
        print(message, file=sys.stderr)
    _pending_notes.clear()


def discard_notes() -> None:
    """Forget the notes held back so far (a new command starts, or the current one failed)."""
    _pending_notes.clear()


def fail(message: str, code: int) -> int:
    """Print `message` as the only line on stderr, dropping the held-back notes; returns `code`."""
    discard_notes()
    print(_one_line(message), file=sys.stderr, flush=True)
    return code


def _one_line(message) -> str:
    return " ".join(str(message).split())


class ProgressBar:
    """A text progress bar on stderr, fed with the fraction done in [0, 1].

    It redraws in place on a terminal and stays silent otherwise (logs and pipes
    get the one-line summary of the command instead of carriage returns), but for
    its label, printed once at the first call, with ``announce=True``.  At
    100 % it ends its line, so that the next bar starts on a fresh one.  Time
    counts from its first call; `seconds` is the time from there to 100 %.  On a
    terminal the elapsed time is redrawn every `tick` seconds meanwhile (None: only
    when the percentage changes), so that a long step without fractions (one large
    solve) still shows that it runs.
    """

    WIDTH = 30
    #: Seconds between redraws of the elapsed time while the percentage stays.
    TICK = 0.5

    def __init__(self, label: str, stream=None, announce: bool = False, tick: float | None = TICK):
        self.label = label
        self.stream = stream or sys.stderr
        self.enabled = self.stream.isatty()
        # Off a terminal, `announce` prints the label once, as a line, at the first call:
        # for a wait that must say what it is (compiling) even in a log.
        self.announce = announce
        self.tick = tick
        self._shown = -1
        self._line = ""
        self._first_call: float | None = None
        self.seconds: float | None = None
        self._lock = threading.Lock()
        self._done = threading.Event()
        self._ticker: threading.Thread | None = None

    def __call__(self, fraction: float) -> None:
        now = time.perf_counter()
        if self._first_call is None:
            self._first_call = now
            if self.announce and not self.enabled:
                self.stream.write(f"{self.label}...\n")
                self.stream.flush()
            if self.enabled and self.tick is not None:
                self._ticker = threading.Thread(target=self._keep_time, daemon=True)
                self._ticker.start()
        percent = int(100 * min(max(fraction, 0.0), 1.0))
        if percent == 100:
            self.seconds = now - self._first_call
        if not self.enabled or percent == self._shown:
            return
        self._draw(percent, now)
        if percent == 100:
            self._stop()

    def _draw(self, percent: int, now: float) -> None:
        with self._lock:
            if self._shown == 100:
                return
            self._shown = percent
            filled = self.WIDTH * percent // 100
            elapsed = now - self._first_call
            self._line = (
                f"{self.label} [{'#' * filled}{'.' * (self.WIDTH - filled)}] {percent:3d}% {elapsed:5.1f} s"
            )
            self.stream.write(f"\r{self._line}")
            if percent == 100:
                self.stream.write("\n")
                self._line = ""
            self.stream.flush()

    def _keep_time(self) -> None:
        while not self._done.wait(self.tick):
            self._draw(self._shown, time.perf_counter())

    def _stop(self) -> None:
        self._done.set()
        if self._ticker is not None and self._ticker is not threading.current_thread():
            self._ticker.join()

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, exc_type, *exc_info) -> None:
        self._stop()
        if self._line:
            # On failure the bar is wiped, so that the error is the only line left.
            self.stream.write("\n" if exc_type is None else f"\r{' ' * len(self._line)}\r")
            self.stream.flush()


@contextlib.contextmanager
def captured_c_stderr() -> Iterator[list[str]]:
    """Collect what C libraries print on file descriptor 2 meanwhile.

    libpng and libjpeg report decoding errors by printing them, outside Python's
    reach, and EGL and Mesa their warnings; capturing them keeps the command line's
    error to one line and lets it quote the library's reason.
    """
    messages: list[str] = []
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as sink:
        os.dup2(sink.fileno(), 2)
        try:
            yield messages
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            sink.seek(0)
            messages.extend(sink.read().decode("utf-8", errors="replace").splitlines())
