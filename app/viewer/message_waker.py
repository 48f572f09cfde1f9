"""Waking the viewer's sleeping loop when a background worker's message or a signal arrives.

An idle window sleeps in ``glfw.wait_events_timeout`` (`app.viewer.window`); a worker's message
(the precompute's progress and results, a check's progress and result) is no window event, so a
thread watches the worker's result pipe and posts an empty event for it.  The loop then draws
what arrived at once instead of polling the pipe several times a second, each poll a frame drawn.
"""

from __future__ import annotations

import multiprocessing.connection
import signal
import socket
import threading
from collections.abc import Callable


class MessageWaker:
    """A thread that calls `wake` whenever a message waits on `connection`.

    After one call it waits until `read` says the messages were read (at most `patience`
    seconds), so a message not yet read does not wake the loop again and again.

    Parameters
    ----------
    connection : multiprocessing.connection.Connection
        The receiving end of a worker's result pipe.
    wake : callable
        Called from the thread (``glfw.post_empty_event``: thread-safe).
    name : str
        The thread's name.
    patience : float
        Seconds between two wakes while the messages stay unread.
    """

    def __init__(self, connection, wake: Callable[[], None], name: str, patience: float = 0.5):
        self._connection, self._wake, self._patience = connection, wake, patience
        self._read = threading.Event()
        self._closing = threading.Event()
        threading.Thread(target=self._watch, name=name, daemon=True).start()

    def _watch(self) -> None:
        while not self._closing.is_set():
            try:
                ready = multiprocessing.connection.wait([self._connection], timeout=self._patience)
            except (OSError, ValueError):
                return  # the pipe is closed
            if ready and not self._closing.is_set():
                self._read.clear()
                self._wake()
                self._read.wait(self._patience)

    def read(self) -> None:
        """The messages waiting were read: the next one wakes the loop again."""
        self._read.set()

    def close(self) -> None:
        """Stop watching (the thread ends within `patience` seconds)."""
        self._closing.set()
        self._read.set()


class SignalWaker:
    """A thread that calls `wake` whenever the process receives a signal that has a Python handler.

    Python runs a signal's handler only between bytecodes, and the idle loop sleeps inside one C
    call (``glfw.wait_events_timeout``, up to `app.viewer.window.IDLE_WAIT` seconds) that retries
    its wait when a signal interrupts it: a ``kill`` (SIGTERM: save and quit) waited for the
    sleep's end. The C-level handler writes the signal's number to a socket
    (``signal.set_wakeup_fd``); the thread reading it calls `wake`, and the loop, awake, runs the
    handler. A context manager: on exit the previous wakeup descriptor comes back.

    Parameters
    ----------
    wake : callable
        Called from the thread (``glfw.post_empty_event``: thread-safe).
    """

    def __init__(self, wake: Callable[[], None]):
        self._wake = wake

    def __enter__(self) -> SignalWaker:
        self._reader, self._writer = socket.socketpair()
        self._writer.setblocking(False)
        self._previous = signal.set_wakeup_fd(self._writer.fileno(), warn_on_full_buffer=False)
        self._closing = threading.Event()
        self._thread = threading.Thread(target=self._watch, name="signal-waker", daemon=True)
        self._thread.start()
        return self

    def _watch(self) -> None:
        while self._reader.recv(64) and not self._closing.is_set():
            self._wake()

    def __exit__(self, *exc_info) -> None:
        signal.set_wakeup_fd(self._previous)
        self._closing.set()
        self._writer.close()  # the reader sees the end of its stream
        self._thread.join()
        self._reader.close()
