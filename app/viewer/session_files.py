"""Where session files live, their rotating backups, and files kept aside instead of overwritten.

Every image (a demo is its image) has one session file, named by the image's
absolute path, so that ``python -m app``, ``view IMAGE`` and ``demo NAME`` find
the same file for the same picture and never one of another picture:
``$XDG_STATE_HOME/transfinite-warp/sessions/STEM-DIGEST.json`` (``~/.local/state``
when ``XDG_STATE_HOME`` is unset; ``$TRANSFINITE_STATE_DIR`` replaces
``$XDG_STATE_HOME/transfinite-warp``).

Nothing here deletes or overwrites a user's file: before an autosave that
changes the document, the previous version becomes ``STEM-DIGEST.backup-1.json``
(and backup k becomes k + 1, up to `BACKUPS`); a file that cannot be read, or
that ``--fresh`` starts over from, is renamed with a time stamp and kept.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import shutil
import time
from pathlib import Path

from core import state_directory

#: Previous versions kept beside each session file.
BACKUPS = 5


def session_path_for(image: str | os.PathLike) -> Path:
    """The autosave file of `image`: the same for every command that opens that file.

    The name is the image's stem (made safe for file names) and the first 10 hex
    digits of the SHA-256 of its absolute path, so that two images of the same
    name in different folders get different sessions.
    """
    resolved = Path(os.path.realpath(image))  # a loop of links is reported when read
    digest = hashlib.sha256(str(resolved).encode("utf-8", "surrogateescape")).hexdigest()[:10]
    stem = "".join(c if c.isalnum() or c in "-_." else "_" for c in resolved.stem) or "image"
    return state_directory() / "sessions" / f"{stem}-{digest}.json"


def backup_path(path: Path, number: int) -> Path:
    """Backup `number` (1 is the newest) of session file `path`."""
    return path.with_name(f"{path.stem}.backup-{number}{path.suffix}")


def backups(path: Path) -> list[Path]:
    """The existing backups of `path`, newest first."""
    return [backup for number in range(1, BACKUPS + 1) if (backup := backup_path(path, number)).exists()]


def rotate_backups(path: Path) -> None:
    """Make the current `path` backup 1, shifting the older backups by one (the oldest is dropped).

    `path` itself stays in place (backup 1 is a hard link to it, or a copy where
    links are not possible), so a crash at any moment leaves the session file whole.
    """
    if not path.exists():
        return
    for number in range(BACKUPS - 1, 0, -1):
        older = backup_path(path, number)
        if older.exists():
            os.replace(older, backup_path(path, number + 1))
    newest = backup_path(path, 1)
    temporary = newest.with_name(f".{newest.name}.tmp")
    with contextlib.suppress(FileNotFoundError):
        temporary.unlink()
    try:
        os.link(path, temporary)
    except OSError:
        shutil.copy2(path, temporary)
    os.replace(temporary, newest)


def keep_aside(path: Path, reason: str) -> Path:
    """Rename `path` to ``STEM.REASON-YYYYmmdd-HHMMSS.json`` beside it (never over another file)."""
    stamp = time.strftime("%Y%m%d-%H%M%S")
    for attempt in range(1000):
        suffix = f"-{attempt}" if attempt else ""
        aside = path.with_name(f"{path.stem}.{reason}-{stamp}{suffix}{path.suffix}")
        if not aside.exists():
            os.rename(path, aside)
            return aside
    raise OSError(f"{path}: no free name to keep it aside")
