"""The per-user secret that keys the checksums of the disk cache (`core.storage.cache`).

A checksum anyone can recompute proves nothing against someone who can write the
cache: an unkeyed SHA-256 of a forged entry is as valid as that of a real one.
The cache's checksums are therefore HMAC-SHA-256 with a random 256-bit key kept
outside the cache, in the state directory: ``$TRANSFINITE_STATE_DIR/cache.key``
if that is set, else ``$XDG_STATE_HOME/transfinite-warp/cache.key``
(``~/.local/state`` when ``XDG_STATE_HOME`` is unset or relative).

The key is made on first use, readable and writable by its owner only, and
created atomically (a complete temporary file linked to its name, so that two
processes starting at once agree on one key).  A key file that another user owns,
that others may read or write, or that is malformed is not used: the cache is
then off (`secret` returns None with the reason) rather than trusting it.
"""

from __future__ import annotations

import contextlib
import functools
import os
import secrets
import stat
from pathlib import Path

from core.storage.state_directory import state_directory

KEY_FILE = "cache.key"
#: Bytes of the key (written as hex).
KEY_BYTES = 32


def key_path() -> Path:
    """The file of the key: `KEY_FILE` in `state_directory`."""
    return state_directory() / KEY_FILE


def secret() -> tuple[bytes | None, str | None]:
    """The key, made if there is none yet; or (None, why it cannot be used)."""
    return _secret(key_path())


@functools.lru_cache(maxsize=8)
def _secret(path: Path) -> tuple[bytes | None, str | None]:
    try:
        if not path.exists():
            _create(path)
        return _read(path), None
    except OSError as error:
        return None, f"{path}: {error.strerror or error}"
    except ValueError as error:
        return None, f"{path}: {error}"


def _create(path: Path) -> None:
    """Write a new random key to `path` unless another process does so first."""
    path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
    descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    try:
        with os.fdopen(descriptor, "w") as stream:
            stream.write(secrets.token_hex(KEY_BYTES) + "\n")
            stream.flush()
            os.fsync(stream.fileno())
        with contextlib.suppress(FileExistsError):  # another process made one meanwhile: use that
            os.link(temporary, path)
    finally:
        with contextlib.suppress(OSError):
            os.remove(temporary)


def _read(path: Path) -> bytes:
    """The key in `path`, or `ValueError` if the file cannot be trusted or is malformed."""
    descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOFOLLOW)
    with os.fdopen(descriptor, "rb") as stream:
        status = os.fstat(descriptor)
        if not stat.S_ISREG(status.st_mode):
            raise ValueError("the cache key is not a regular file")
        if status.st_uid != os.getuid():
            raise ValueError("the cache key belongs to another user")
        if status.st_mode & 0o077:
            mode = status.st_mode & 0o777
            raise ValueError(f"others may read or write the cache key (mode {mode:o}); chmod 600 it")
        text = stream.read(4 * KEY_BYTES).strip()
    try:
        key = bytes.fromhex(text.decode("ascii"))
    except (UnicodeDecodeError, ValueError):
        key = b""
    if len(key) != KEY_BYTES:
        raise ValueError(f"the cache key is not {2 * KEY_BYTES} hex digits")
    return key
