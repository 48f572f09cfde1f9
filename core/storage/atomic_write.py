"""Atomic file writes: a temporary file in the same directory, then `os.replace`.

A reader sees either the old file or the new one, never a part.  Temporaries are
named ``.NAME.PID.RANDOM.tmp`` (`temporary_path`; a NAME too long for that, near the
255 bytes a file name may have, is shortened to its start and a digest of it); a
process killed between creating one and the rename leaves it behind, so every
write first removes those of a process that no longer runs.  New files get the
mode the umask gives (as ``open`` would), a replaced file keeps its mode.
"""

from __future__ import annotations

import contextlib
import hashlib
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
    temporary = temporary_path(path)
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


#: Longest file name in bytes (NAME_MAX of Linux, macOS and Windows' filesystems).
NAME_MAX = 255
#: Bytes a temporary name adds to NAME: ``.`` and ``.PID.RANDOM.tmp`` with a 10-digit process id
#: and a suffix of up to 8 bytes.
_TEMPORARY_OVERHEAD = 1 + 1 + 10 + 1 + 8 + 4 + 8
_DIGEST_LENGTH = 8


def temporary_path(path: str | os.PathLike, suffix: str = "") -> Path:
    """A new temporary name beside `path`, ``.NAME.PID.RANDOM.tmp`` + `suffix` (at most 8 bytes).

    Temporaries of a killed earlier process are removed first (`remove_stale_temporaries`).
    """
    path = Path(path)
    remove_stale_temporaries(path)
    return path.parent / f".{_stem(path.name)}.{os.getpid()}.{secrets.token_hex(4)}.tmp{suffix}"


def _stem(name: str) -> str:
    """NAME as temporary names hold it: itself, or if the temporary would exceed `NAME_MAX`
    bytes, its longest start that fits (whole characters) and ``~`` and a digest of all of it."""
    encoded = os.fsencode(name)
    room = NAME_MAX - _TEMPORARY_OVERHEAD
    if len(encoded) <= room:
        return name
    digest = hashlib.sha256(encoded).hexdigest()[:_DIGEST_LENGTH]
    start = encoded[: room - 1 - _DIGEST_LENGTH].decode("utf-8", errors="ignore")
    return f"{start}~{digest}"


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
    pattern = re.compile(rf"\.{re.escape(_stem(path.name))}\.(\d+)\.[0-9a-f]{{8}}\.tmp(\.\w+)?")
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
