"""Waking the viewer's sleeping loop when a background worker's message arrives.

An idle window sleeps in ``glfw.wait_events_timeout`` (`app.viewer.window`); a worker's message
(the precompute's progress and results, a check's progress and result) is no window event, so a
thread watches the worker's result pipe and posts an empty event for it.  The loop then draws
what arrived at once instead of polling the pipe several times a second, each poll a frame drawn.
"""

from __future__ import annotations

import multiprocessing.connection
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
