"""Atomic file writes: a temporary file in the same directory, then `os.replace`.

A reader sees either the old file or the new one, never a part.  Temporaries are
named ``.NAME.PID.RANDOM.tmp``; a process killed between creating one and the
rename leaves it behind, so every write first removes those of a process that no
longer runs.  New files get the mode the umask gives (as ``open`` would), a
replaced file keeps its mode.
"""

from __future__ import annotations

import contextlib
import os
import re
import secrets
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO


def write_atomically(path: str | os.PathLike, write: Callable[[BinaryIO], None]) -> None:
    """Call ``write(stream)`` on a temporary file, flush it to disk, and rename it to `path`.

    Raises
    ------
    OSError
        If any step fails; `path` is then unchanged and the temporary file removed.
    """
    path = Path(path)
    remove_stale_temporaries(path)
    temporary = path.parent / f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp"
    mode = path.stat().st_mode & 0o7777 if path.exists() else None
    # 0o666 through os.open: the umask decides the mode of a new file.
    handle = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(handle, "wb") as stream:
            write(stream)
            stream.flush()
            os.fsync(stream.fileno())
        if mode is not None:
            os.chmod(temporary, mode)
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.remove(temporary)
        raise


def remove_stale_temporaries(path: str | os.PathLike) -> list[Path]:
    """Remove the temporaries of `path` left by processes that no longer run; return them.

    Temporaries are ``.NAME.PID.RANDOM.tmp``, optionally with a suffix of their own
    (``.tmp.mp4``, ``.tmp.old``), files or folders (a folder of frames).
    """
    removed = []
    for stale in abandoned_temporaries(path):
        with contextlib.suppress(OSError):
            if stale.is_dir() and not stale.is_symlink():
                shutil.rmtree(stale)
            else:
                os.remove(stale)
            removed.append(stale)
    return removed


def abandoned_temporaries(path: str | os.PathLike) -> list[Path]:
    """The temporaries of `path` (see `remove_stale_temporaries`) whose process no longer runs,
    the most recently modified first.  A process killed after writing one whole but before the
    rename leaves the newest version of `path` there."""
    path = Path(path)
    pattern = re.compile(rf"\.{re.escape(path.name)}\.(\d+)\.[0-9a-f]{{8}}\.tmp(\.\w+)?")
    try:
        names = os.listdir(path.parent)
    except OSError:
        return []
    found = []
    for name in names:
        match = pattern.fullmatch(name)
        if match and not _running(int(match.group(1))):
            with contextlib.suppress(OSError):
                found.append((os.lstat(path.parent / name).st_mtime_ns, path.parent / name))
    return [stale for _, stale in sorted(found, reverse=True)]


def _running(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    except OverflowError:  # not a process id at all
        return False
    return True
