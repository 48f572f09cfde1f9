"""On-disk cache of basis-function matrices G (V x n) at mesh vertices, and of their gradients.

Computing G once per (cage, mesh, kernel) is the precompute of Sec. 4.3; it can
take seconds, so the result is kept in a ``.npz`` file named by the SHA-256 of
everything it depends on (`cache_key`).  The directory is ``$TRANSFINITE_CACHE_DIR``
if set, else ``$XDG_CACHE_HOME/transfinite-warp`` (``~/.cache/transfinite-warp``
when ``XDG_CACHE_HOME`` is unset, following the XDG base directory specification).

A cache must never change a result.  Each file holds the array, the errors of
its invariants measured when it was computed (`core.mesh_basis` checks them on
every read, and recomputes a few rows at random to compare) and a checksum of
the key, the shape, the errors and the array's bytes: an HMAC-SHA-256 keyed
with a per-user secret kept outside the cache (`core.storage.cache_secret`), so that
whoever can write the cache but not read the secret cannot forge an entry.
`load` reports a file that cannot be read, does not hold what was stored under
its key, or fails the checksum as a problem (the caller recomputes and `store`
replaces it); files are written atomically (`core.storage.atomic_write`) with the mode
the umask gives.  Without a usable secret the cache is off, with one warning.
"""

from __future__ import annotations

import functools
import hashlib
import hmac
import json
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core.storage.atomic_write import write_atomically
from core.storage.cache_secret import secret

# Bump when the meaning or layout of a cached array changes (3: keyed checksums).
FORMAT_VERSION = 3
ENVIRONMENT_VARIABLE = "TRANSFINITE_CACHE_DIR"
#: The folder of `core`, whose numerical modules enter every key.
CORE_FOLDER = Path(__file__).resolve().parent.parent
#: The modules of `core` whose code cannot change a cached value; every other module's code is
#: hashed into every key (`_code_digest`), so that a new numerical module is covered unlisted.
#: Paths in `core`; the packages' ``__init__.py`` are left out too.
#: (A list of the numerical modules instead had missed the boundary-integral kernels: a
#: corrected `poisson` still read the bases its old code had cached.)
NON_NUMERICAL_MODULES = frozenset(
    {
        "library_threads.py", "curves/examples.py", "jit_cache.py", "newton/compilation.py",
        "newton/reference.py", "storage/atomic_write.py", "storage/cache.py",
        "storage/cache_secret.py", "storage/state_directory.py",
    }
)  # fmt: skip


def cache_directory() -> Path:
    """The cache directory: ``$TRANSFINITE_CACHE_DIR``, or ``transfinite-warp`` in ``$XDG_CACHE_HOME``
    (``~/.cache`` if that is unset or, as the XDG specification says, not an absolute path)."""
    configured = os.environ.get(ENVIRONMENT_VARIABLE)
    if configured:
        return Path(configured).expanduser()
    base = Path(os.environ.get("XDG_CACHE_HOME", ""))
    if not base.is_absolute():
        base = Path.home() / ".cache"
    return base / "transfinite-warp"


def cache_key(
    control_points: np.ndarray,
    vertices: np.ndarray,
    triangles: np.ndarray,
    boundary: np.ndarray,
    boundary_parameters: np.ndarray,
    kernel: str,
    samples_per_segment: int,
    params: dict,
    parameterization: str = "natural",
    quantity: str = "basis functions",
) -> str:
    """Hex SHA-256 of the format version, the numerical code, the cage, the mesh, the kernel,
    its parameters, the boundary's parameterisation (`core.curves.arc_length`) and what is stored
    (``"basis functions"`` or ``"basis gradients"``).

    Arrays enter with their dtype and shape, so that equal bytes of different
    shapes give different keys.
    """
    digest = hashlib.sha256()
    digest.update(f"transfinite-warp {quantity}, format {FORMAT_VERSION}\n".encode())
    digest.update(_code_digest().encode())
    for array, dtype in (
        (control_points, np.float64),
        (vertices, np.float64),
        (triangles, np.int64),
        (boundary, np.int64),
        (boundary_parameters, np.float64),
    ):
        array = np.ascontiguousarray(array, dtype=dtype)
        digest.update(f"{array.dtype.str}{array.shape}\n".encode())
        digest.update(array.tobytes())
    settings = {
        "kernel": kernel,
        "samples_per_segment": int(samples_per_segment),
        "parameterization": parameterization,
        "params": sorted((name, _canonical(value)) for name, value in params.items()),
    }
    digest.update(json.dumps(settings, sort_keys=True).encode())
    return digest.hexdigest()


@dataclass(frozen=True)
class Entry:
    """What `load` found for a key.

    Attributes
    ----------
    values : ndarray of shape (V, n) or None
        The stored array, if the file is intact.
    errors : ndarray of shape (2,) or None
        Its partition-of-unity and linear-precision errors when it was stored.
    problem : str or None
        Why an existing file was rejected; None if it is intact or absent.
    """

    values: np.ndarray | None = None
    errors: np.ndarray | None = None
    problem: str | None = None


def entry_path(key: str) -> Path:
    """The file of `key` in `cache_directory`."""
    return cache_directory() / f"{key}.npz"


def load(key: str, shape: tuple[int, ...]) -> Entry:
    """The intact float64 array of `shape` stored for `key`, or why there is none.

    Without a usable secret (`core.storage.cache_secret`) nothing is read: an `Entry` without values.
    """
    if _usable_secret() is None:
        return Entry()
    path = entry_path(key)
    try:
        # Our own stream: np.load leaves the file open when the zip is broken.
        with open(path, "rb") as stream, np.load(stream, allow_pickle=False) as file:
            values, errors, checksum = file["basis"], file["errors"], str(file["checksum"])
    except (FileNotFoundError, NotADirectoryError):
        return Entry()
    except Exception as error:  # truncated, not a .npz, bad zip CRC, missing member: recompute
        return Entry(problem=f"unreadable: {type(error).__name__}")
    if values.dtype != np.float64 or values.shape != tuple(shape):
        return Entry(problem=f"a {values.dtype} array of shape {values.shape}, expected {tuple(shape)}")
    if errors.dtype != np.float64 or errors.shape != (2,):
        return Entry(problem="its invariant errors are malformed")
    if checksum != _checksum(key, values, errors):
        # Changed since it was written, or written under another key (another user's cache, or a
        # state directory made anew): either way it cannot be trusted.
        return Entry(problem="checksum mismatch: changed since written, or written under another key")
    if not (np.isfinite(values).all() and np.isfinite(errors).all()):
        return Entry(problem="non-finite values")
    return Entry(values, errors)


def store(key: str, values: np.ndarray, errors: np.ndarray) -> bool:
    """Write `values` (V, n), or gradients (V, n, 2), and their invariant `errors` (2,) for `key` atomically.

    Returns whether it was written; warns (never raises) if the directory is not writable, and
    writes nothing without a usable secret (`core.storage.cache_secret`).
    """
    if _usable_secret() is None:
        return False
    values = np.ascontiguousarray(values, dtype=np.float64)
    errors = np.ascontiguousarray(errors, dtype=np.float64)
    checksum = np.array(_checksum(key, values, errors))
    directory = cache_directory()
    try:
        directory.mkdir(parents=True, exist_ok=True)
        write_atomically(
            entry_path(key), lambda stream: np.savez(stream, basis=values, errors=errors, checksum=checksum)
        )
    except OSError as error:
        warnings.warn(
            f"could not write the basis-function cache in {directory} ({error}); "
            f"set {ENVIRONMENT_VARIABLE} to a writable directory",
            RuntimeWarning,
            stacklevel=3,
        )
        return False
    return True


def _checksum(key: str, values: np.ndarray, errors: np.ndarray) -> str:
    """Hex HMAC-SHA-256, keyed with the user's secret, of the key, the array's dtype, shape and
    bytes, and the errors."""
    digest = hmac.new(_usable_secret(), key.encode(), hashlib.sha256)
    for array in (values, errors):
        array = np.ascontiguousarray(array)
        digest.update(f"{array.dtype.str}{array.shape}\n".encode())
        digest.update(array.tobytes())
    return digest.hexdigest()


def _usable_secret() -> bytes | None:
    """The secret of the checksums, or None (with a warning, once per reason) if there is none."""
    key, problem = secret()
    if key is None:
        _warn_once(
            f"the basis-function cache is off: its key cannot be used ({problem}); remove the file, "
            "or set TRANSFINITE_STATE_DIR to a private writable directory"
        )
    return key


@functools.cache
def _warn_once(message: str) -> None:
    warnings.warn(message, RuntimeWarning, stacklevel=4)


@functools.cache
def _code_digest() -> str:
    """SHA-256 of the modules of `core` that compute G (all but `NON_NUMERICAL_MODULES` and the
    packages' ``__init__.py``), each with its path in `core`: a changed solver never reads stale
    results."""
    digest = hashlib.sha256()
    folder = CORE_FOLDER
    for path in sorted(folder.rglob("*.py")):
        name = path.relative_to(folder).as_posix()
        if name not in NON_NUMERICAL_MODULES and path.name != "__init__.py":
            digest.update(name.encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def _canonical(value):
    """A JSON-stable form of a parameter value (numpy scalars as Python numbers)."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, (bool, int, float, str)) or value is None:
        return value
    return repr(value)
