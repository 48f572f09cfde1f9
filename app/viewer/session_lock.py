"""One viewer per session file: an advisory lock held while a viewer shows it.

Two viewers on the same image autosave into the same session file, and the
last autosave wins: the other viewer's edits would be lost.  So a viewer holds
an exclusive ``flock`` on a lock file of its session while it shows it, and a
second viewer (another process) asking for the same session is refused with
one line that names the first one's process and the way out (``--session FILE``
for a separate copy).  The operating system drops the lock when the holder
exits for any reason, ``kill -9`` included, so a crashed viewer never locks a
session out.  A process forked from the viewer (its precompute worker,
`app.viewer.precompute`) closes its copies of the lock files at once: a copy would keep the lock
held after the viewer itself is gone.

Lock files live in the state directory (``locks/DIGEST.lock``, DIGEST from the
session file's absolute path), never beside a user's own ``--session`` file.
Where ``fcntl`` does not exist (Windows) sessions are not locked.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import weakref
from pathlib import Path

from app.io.files import InputError
from app.viewer.session_files import state_directory

try:
    import fcntl
except ImportError:  # pragma: no cover - not on the platforms the tests run on
    fcntl = None


class SessionBusy(InputError):
    """The session file is shown by a viewer in another process."""


class SessionLock:
    """The lock of one session file, held by this process until the object is dropped.

    Opening the same session again in this process (Ctrl+O on the image shown)
    gives the same object, so a process never locks itself out.
    """

    def __init__(self, session: Path, descriptor: int):
        self.session = session
        self.descriptor = descriptor
        self._close = weakref.finalize(self, os.close, descriptor)

    def release(self) -> None:
        """Give the lock up now (it is given up anyway when the object is dropped)."""
        _held.pop(str(self.session), None)
        self._close()


#: The locks this process holds, by the session file's absolute path.
_held: weakref.WeakValueDictionary[str, SessionLock] = weakref.WeakValueDictionary()


def _close_inherited() -> None:
    """In a child just forked: close this process's copies of the lock files, without unlocking
    (``flock`` belongs to the open file, which the parent still holds: an unlock here would
    unlock the parent's too), and forget the locks, which are the parent's."""
    for lock in list(_held.values()):
        lock._close.detach()
        with contextlib.suppress(OSError):
            os.close(lock.descriptor)
    _held.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_close_inherited)


def lock_file_for(session: Path) -> Path:
    """Where the lock of session file `session` lives."""
    digest = hashlib.sha256(os.path.realpath(session).encode("utf-8", "surrogateescape")).hexdigest()[:16]
    return state_directory() / "locks" / f"{digest}.lock"


def lock_session(session: Path) -> SessionLock | None:
    """Lock session file `session` for this process (None where locks are not supported).

    Raises
    ------
    SessionBusy
        Another process holds the lock: the message names it and the ways out.
    """
    if fcntl is None:
        return None
    key = os.path.realpath(session)
    held = _held.get(key)
    if held is not None:
        return held
    path = lock_file_for(session)
    path.parent.mkdir(parents=True, exist_ok=True)
    descriptor = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        owner = _owner(descriptor)
        os.close(descriptor)
        raise SessionBusy(
            f"{session} is open in another viewer{owner}: close that one first, "
            "or open a separate copy with --session FILE"
        ) from None
    except OSError:  # a file system without locks: work as before rather than refuse
        os.close(descriptor)
        return None
    os.ftruncate(descriptor, 0)
    os.write(descriptor, f"{os.getpid()}\n".encode())
    lock = SessionLock(Path(key), descriptor)
    _held[key] = lock
    return lock


def _owner(descriptor: int) -> str:
    """`` (process PID)`` from the lock file, or nothing if it cannot be read."""
    with contextlib.suppress(OSError, ValueError):
        text = os.pread(descriptor, 32, 0).decode().strip()
        if text.isdigit():
            return f" (process {int(text)})"
    return ""
