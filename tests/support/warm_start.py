"""Viewers (and commands) started from a warm process: ``python -m app ...`` without loading its
libraries again.

A viewer's start costs ~2.5 CPU-s, about half of it loading numpy, numba, scipy, OpenCV, imgui,
moderngl and the app's own modules and numba's compiled-code machinery (its first use of a cached
function, in the viewer's precompute worker).  The window tests start ~35 viewers, each the same
program, so each pytest process starts them from one preloaded server instead (`multiprocessing`'s
forkserver, which imports `preload` once): each viewer is a fork of it that takes its arguments,
environment, working folder, stdout and stderr, and runs `app.__main__.main` as ``python -m app``
would, Ctrl+C included (an interpreter started from a terminal raises KeyboardInterrupt on SIGINT,
whatever the server inherited).  What it runs is the real program in a real process with its own
window and workers; what the fork skips is only what the server loaded already.  Starting the
program itself (its imports, a display or none) stays tested by real processes
(`tests/app/viewer/test_window.py`'s environment errors, the bench's launch rows, the installed
wheel's demo).
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import subprocess
import sys
import threading
from multiprocessing import forkserver
from multiprocessing.connection import Connection

from support.paths import ROOT

#: What the server imports before it forks viewers: this module's `preload` runs at its import.
PRELOAD = "support.warm_start_preload"


def start(args: list[str], env: dict, cwd) -> WarmProcess:
    """``python -m app *args`` forked from the warm server, with `env` as its whole environment
    and `cwd` its working folder; its stdout and stderr are pipes (text), as `subprocess.Popen`'s."""
    context = multiprocessing.get_context("forkserver")
    _ensure_server(context)
    out_read, out_write = os.pipe()
    err_read, err_write = os.pipe()
    streams = (Connection(out_write, readable=False), Connection(err_write, readable=False))
    process = context.Process(target=_run, args=(list(args), dict(env), str(cwd), streams), name="viewer")
    try:
        process.start()
    finally:
        for stream in streams:
            stream.close()
    return WarmProcess(process, os.fdopen(out_read, "r"), os.fdopen(err_read, "r"))


def _ensure_server(context) -> None:
    """Start the server if it is not running, with the repository and the tests' folder on its
    path (Python 3.11's forkserver takes the environment's, not this process's `sys.path`)."""
    context.set_forkserver_preload([PRELOAD])
    saved = os.environ.get("PYTHONPATH")
    os.environ["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), str(ROOT / "tests"), saved]))
    try:
        forkserver.ensure_running()
    finally:
        if saved is None:
            del os.environ["PYTHONPATH"]
        else:
            os.environ["PYTHONPATH"] = saved


class WarmProcess:
    """The parts of `subprocess.Popen` that the viewer tests use, for a process of `start`."""

    def __init__(self, process: multiprocessing.Process, stdout, stderr):
        self._process = process
        self.pid = process.pid
        self.stdout, self.stderr = stdout, stderr
        self.returncode: int | None = None

    def poll(self) -> int | None:
        self.returncode = self._process.exitcode
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        self._process.join(timeout)
        if self.poll() is None:
            raise subprocess.TimeoutExpired("python -m app", timeout)
        return self.returncode

    def communicate(self, timeout: float | None = None) -> tuple[str, str]:
        """Wait for the exit; (stdout, stderr) whole, read meanwhile so that neither pipe fills."""
        read = {}
        readers = [
            threading.Thread(target=lambda name, stream: read.update({name: stream.read()}), args=item)
            for item in (("out", self.stdout), ("err", self.stderr))
        ]
        for reader in readers:
            reader.start()
        self.wait(timeout)
        for reader in readers:
            reader.join(timeout)
        return read.get("out", ""), read.get("err", "")

    def send_signal(self, number: int) -> None:
        if self.poll() is None:
            os.kill(self.pid, number)

    def terminate(self) -> None:
        self._process.terminate()

    def kill(self) -> None:
        self._process.kill()


def _run(args: list[str], env: dict, cwd: str, streams: tuple[Connection, Connection]) -> None:
    """The forked viewer: `env`, `cwd`, the streams on file descriptors 1 and 2, then the program."""
    for number, stream in zip((1, 2), streams, strict=True):
        os.dup2(stream.fileno(), number)
        stream.close()
    os.environ.clear()
    os.environ.update(env)
    os.chdir(cwd)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    from app import __main__ as program

    sys.argv = [program.__file__, *args]
    code = program.main(args)
    sys.stdout.flush()
    sys.exit(code)
