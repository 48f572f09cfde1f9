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
in a child process with the build environment's packages (`COMPILE_REQUIRES`, which the
backend adds to `pyproject.toml`'s ``[build-system] requires`` only for a build that
compiles); if it fails, the build goes on without the cache and says why.

- ``TRANSFINITE_PRECOMPILE=0`` skips it (and the build environment then holds setuptools
  alone: an editable install takes seconds instead of half a minute of unpacking scipy and numba).
- ``TRANSFINITE_PRECOMPILED=<folder>`` ships the cache already compiled in ``<folder>``, laid
  out as `core` (``<folder>/newton/__pycache__/...``), instead of compiling: for a build of the
  same sources as a checkout whose cache `compile_all` has just filled (``.ci/run`` builds the
  wheel that way).  numba stamps each function with the content of `core`'s compiled modules
  (`core.jit_cache`): where the sources differ, the shipped files are stale and the installed
  package compiles on first use, which ``tests/packaging/test_wheel.py`` would catch.
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
    get_requires_for_build_sdist,
    prepare_metadata_for_build_editable,
    prepare_metadata_for_build_wheel,
)

ROOT = Path(__file__).resolve().parent.parent
#: The package whose `__pycache__` folders (its own and its subpackages') hold numba's cache.
CORE = ROOT / "core"
#: What the compilation imports (`import core`), at the versions of `pyproject.toml`'s dependencies.
COMPILE_REQUIRES = ["numpy>=2.0", "scipy>=1.13", "numba>=0.61", "threadpoolctl>=3.1"]


def _compiles() -> bool:
    """Whether this build runs the compilation (in a build environment that needs `COMPILE_REQUIRES`)."""
    skipped = os.environ.get("TRANSFINITE_PRECOMPILE", "1") == "0"
    return not skipped and not os.environ.get("TRANSFINITE_PRECOMPILED")


def get_requires_for_build_wheel(config_settings=None):
    required = _setuptools.get_requires_for_build_wheel(config_settings)
    return required + (COMPILE_REQUIRES if _compiles() else [])


def get_requires_for_build_editable(config_settings=None):
    required = _setuptools.get_requires_for_build_editable(config_settings)
    return required + (COMPILE_REQUIRES if _compiles() else [])


def _precompile(fresh: bool) -> None:
    """Compile `core` into numba's in-tree cache (`core.newton.compilation.compile_all`).

    With `fresh`, numba's files of `core` are deleted first, so that the folder holds
    exactly what the current sources compile to (a wheel ships it whole).
    """
    if os.environ.get("TRANSFINITE_PRECOMPILE", "1") == "0":
        print("transfinite-warp: TRANSFINITE_PRECOMPILE=0: the solver compiles on first use", file=sys.stderr)
        return
    if fresh:
        for path in _numba_files(CORE):
            path.unlink()
    compiled = os.environ.get("TRANSFINITE_PRECOMPILED")
    if compiled:
        _copy_compiled(Path(compiled))
        return
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


def _numba_files(folder: Path) -> list[Path]:
    """numba's cache files under `folder` (``*/__pycache__/*.nbi``, ``*.nbc``)."""
    return [*folder.rglob("__pycache__/*.nbi"), *folder.rglob("__pycache__/*.nbc")]


def _copy_compiled(folder: Path) -> None:
    """Copy numba's files of a compiled copy of `core` (`folder`, laid out as `core`) into `CORE`."""
    files = _numba_files(folder)
    if not files:
        raise RuntimeError(f"TRANSFINITE_PRECOMPILED={folder}: no compiled files (*/__pycache__/*.nbi) there")
    for path in files:
        target = CORE / path.relative_to(folder)
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(path.read_bytes())
    print(f"transfinite-warp: the solver's cache copied from {folder} ({len(files)} files)", file=sys.stderr)


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
