"""This process's ends of its workers' pipes, which a child forked from it closes at once.

A worker learns that the viewer is gone (closed, or killed with ``kill -9``) when the pipe it
reads requests from reports the end of the file: every copy of the writing end is closed.  A
worker forked from the viewer (`app.viewer.precompute.start_method`) starts with copies of the
viewer's ends of every pipe made so far, its own included, so without this it would never see
that end and would compute on after the viewer is gone.  Registered ends are closed in every
child forked from this process (``os.register_at_fork``), whoever forks it.
"""

from __future__ import annotations

import os
import weakref
from multiprocessing.connection import Connection

_ends: weakref.WeakSet[Connection] = weakref.WeakSet()


def keep_from_forks(*connections: Connection) -> None:
    """Close `connections` in every child this process forks from now on."""
    _ends.update(connections)


def _close_in_child() -> None:
    for connection in list(_ends):
        try:
            connection.close()
        except OSError:
            pass
    _ends.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_close_in_child)
