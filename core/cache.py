"""On-disk cache of basis-function matrices G (V x n) at mesh vertices.

Computing G once per (cage, mesh, kernel) is the precompute of Sec. 4.3; it can
take seconds, so the result is kept as a ``.npy`` file named by the SHA-256 of
everything it depends on.  The directory is ``$TRANSFINITE_CACHE_DIR`` if set, else
``$XDG_CACHE_HOME/transfinite-warp`` (``~/.cache/transfinite-warp`` when
``XDG_CACHE_HOME`` is unset, following the XDG base directory specification).
Files are written atomically (a temporary file in the same directory, then
`os.replace`), and a file that cannot be read or does not hold the expected finite
array is ignored: the caller recomputes it.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import tempfile
import warnings
from pathlib import Path

import numpy as np

# Bump when the meaning or layout of a cached array changes.
FORMAT_VERSION = 1
ENVIRONMENT_VARIABLE = "TRANSFINITE_CACHE_DIR"
# The modules whose code decides the cached values (hashed into every key).
NUMERICAL_MODULES = (
    "basis.py",
    "boundary.py",
    "bspline.py",
    "harmonic.py",
    "kernels.py",
    "mesh_basis.py",
    "pgw.py",
    "solver.py",
)


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
) -> str:
    """Hex SHA-256 of the format version, the numerical code, the cage, the mesh, the kernel
    and its parameters.

    Arrays enter with their dtype and shape, so that equal bytes of different
    shapes give different keys.
    """
    digest = hashlib.sha256()
    digest.update(f"transfinite-warp basis functions, format {FORMAT_VERSION}\n".encode())
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
        "params": sorted((name, _canonical(value)) for name, value in params.items()),
    }
    digest.update(json.dumps(settings, sort_keys=True).encode())
    return digest.hexdigest()


def load(key: str, shape: tuple[int, int]) -> np.ndarray | None:
    """The cached float64 array of `shape` for `key`, or None if absent, unreadable or wrong."""
    path = cache_directory() / f"{key}.npy"
    try:
        array = np.load(path, allow_pickle=False)
    except Exception:  # missing, truncated, not .npy, unreadable: recompute, never crash
        return None
    if array.dtype != np.float64 or array.shape != tuple(shape) or not np.isfinite(array).all():
        return None
    return array


def store(key: str, array: np.ndarray) -> None:
    """Write `array` for `key` atomically; warn (never raise) if the directory is not writable."""
    directory = cache_directory()
    temporary = None
    try:
        directory.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(
            dir=directory, prefix=f".{key}.", suffix=".tmp", delete=False
        ) as file:
            temporary = file.name
            np.save(file, np.ascontiguousarray(array, dtype=np.float64), allow_pickle=False)
        os.replace(temporary, directory / f"{key}.npy")
    except OSError as error:
        if temporary is not None:
            try:
                os.unlink(temporary)
            except OSError:
                pass
        warnings.warn(
            f"could not write the basis-function cache in {directory} ({error}); "
            f"set {ENVIRONMENT_VARIABLE} to a writable directory",
            RuntimeWarning,
            stacklevel=3,
        )


@functools.cache
def _code_digest() -> str:
    """SHA-256 of the modules that compute G: a changed solver never reads stale results."""
    digest = hashlib.sha256()
    folder = Path(__file__).resolve().parent
    for name in NUMERICAL_MODULES:
        digest.update((folder / name).read_bytes())
    return digest.hexdigest()


def _canonical(value):
    """A JSON-stable form of a parameter value (numpy scalars as Python numbers)."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, (bool, int, float, str)) or value is None:
        return value
    return repr(value)
