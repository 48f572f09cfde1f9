"""The package's build backend: setuptools, with numba's cache of `core` built into the package.

The Newton kernels, their gradients and the positive Gordon-Wixom rows run code that
numba compiles on first use (~30 s of one core on a 2-core machine).  This backend runs
that compilation once while the package is built, so that an installed package starts
every kernel from the cache:

- ``pip install -e .`` (``build_editable``) compiles into the ``__pycache__`` folders of `core`'s
  subpackages in the source tree, where the editable install imports `core` from; a cache that is already
  fresh loads in about a second instead.
- ``pip wheel .`` / ``pip install .`` (``build_wheel``) compiles from scratch and ships
  the files (``core/*/__pycache__/*.nbi``, ``*.nbc``) in the wheel as package data
  (`pyproject.toml` lists every subpackage that holds compiled functions).

numba uses a cached function only where the numba version, the Python version, the CPU
model and the function's source all match the build's (the build environment gets
the same newest numba as the installed package, `pyproject.toml` lists it); anywhere
else the code is compiled on first use, as without this backend.  The compilation runs
in a child process with the build environment's packages (`pyproject.toml`'s
``[build-system] requires``); if it fails, the build goes on without the cache and
says why.  ``TRANSFINITE_PRECOMPILE=0`` skips it.
"""

from __future__ import annotations

import io
import os
import subprocess
import sys
import tarfile
import time
from pathlib import Path

from setuptools import build_meta as _setuptools
from setuptools.build_meta import (  # noqa: F401  (the hooks this backend does not change)
    get_requires_for_build_editable,
    get_requires_for_build_sdist,
    get_requires_for_build_wheel,
    prepare_metadata_for_build_editable,
    prepare_metadata_for_build_wheel,
)

ROOT = Path(__file__).resolve().parent.parent
#: The package whose `__pycache__` folders (its own and its subpackages') hold numba's cache.
CORE = ROOT / "core"


def _precompile(fresh: bool) -> None:
    """Compile `core` into numba's in-tree cache (`core.newton.compilation.compile_all`).

    With `fresh`, numba's files of `core` are deleted first, so that the folder holds
    exactly what the current sources compile to (a wheel ships it whole).
    """
    if os.environ.get("TRANSFINITE_PRECOMPILE", "1") == "0":
        print("transfinite-warp: TRANSFINITE_PRECOMPILE=0: the solver compiles on first use", file=sys.stderr)
        return
    if fresh:
        for path in [*CORE.rglob("__pycache__/*.nbi"), *CORE.rglob("__pycache__/*.nbc")]:
            path.unlink()
    environment = {key: value for key, value in os.environ.items() if key != "NUMBA_CACHE_DIR"}
    environment["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), environment.get("PYTHONPATH")]))
    print("transfinite-warp: compiling the solver into the package (~30 s)", file=sys.stderr, flush=True)
    start = time.perf_counter()
    result = subprocess.run(
        [sys.executable, "-c", "from core.newton.compilation import compile_all; compile_all()"],
        cwd=ROOT,
        env=environment,
        capture_output=True,
        text=True,
    )
    if result.returncode != 0:
        last = (result.stderr.strip().splitlines() or ["no output"])[-1]
        print(
            f"transfinite-warp: warning: the solver was not compiled into the package ({last}); "
            "it compiles on first use instead",
            file=sys.stderr,
        )
        return
    print(f"transfinite-warp: compiled in {time.perf_counter() - start:.0f} s", file=sys.stderr)


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    _precompile(fresh=True)
    return _setuptools.build_wheel(wheel_directory, config_settings, metadata_directory)


def build_sdist(sdist_directory, config_settings=None):
    """setuptools' source distribution, with this backend added: `pyproject.toml` names it
    (``backend-path``), so a build from the sdist needs it, and setuptools packs only the
    packages, their data and the top-level files (a ``MANIFEST.in`` would be a new top-level
    file).  The archive is rewritten under a temporary name, then renamed over the original;
    if setuptools already packed the backend, it is left as it is."""
    name = _setuptools.build_sdist(sdist_directory, config_settings)
    path = Path(sdist_directory) / name
    backend = Path(__file__).resolve()
    with tarfile.open(path, "r:gz") as source:
        members = source.getmembers()
        root = members[0].name.split("/")[0]
        inside = f"{root}/.packaging/{backend.name}"
        if any(member.name == inside for member in members):
            return name
        partial = path.with_name(path.name + ".partial")
        try:
            with tarfile.open(partial, "w:gz", format=tarfile.PAX_FORMAT) as target:
                for member in members:
                    target.addfile(member, source.extractfile(member) if member.isfile() else None)
                data = backend.read_bytes()
                info = tarfile.TarInfo(inside)
                info.size, info.mtime, info.mode = len(data), int(backend.stat().st_mtime), 0o644
                target.addfile(info, io.BytesIO(data))
        except BaseException:
            partial.unlink(missing_ok=True)
            raise
    partial.replace(path)
    return name


def build_editable(wheel_directory, config_settings=None, metadata_directory=None):
    _precompile(fresh=False)
    return _setuptools.build_editable(wheel_directory, config_settings, metadata_directory)
