"""numba's on-disk cache, or an uncached compilation where no cache folder can be written.

``@njit(cache=True)`` looks for a writable folder when a function is defined (at
import): ``NUMBA_CACHE_DIR``, else ``__pycache__`` beside the source, else
numba's user-wide cache (``$XDG_CACHE_HOME/numba``, ``~/.cache/numba``).  Where
none can be written (a read-only install with an unwritable home) numba raises
``cannot cache function '_slab': no locator available`` and the package would
not import.  Imported first by `core`, this module makes such functions of the
package compile without the cache instead, and says so in one line on stderr:
everything works, only each run compiles again.

numba also checks a cached function against its own source file only, while a compiled
function carries the machine code of the functions it calls, from other modules too
(`core.gradient_solver` and `core.closest_point` call `core.solver`): after an edit of
the callee alone the caller's cache would still run the old code.  Here every compiled
function of the package is stamped with the content of all of the package's modules that
hold compiled functions (`_PackageLocator`), so any edit of one recompiles them all.
"""

from __future__ import annotations

import functools
import hashlib
import re
import sys
from pathlib import Path

from numba.core.caching import CacheImpl, NullCache, _CacheLocator
from numba.core.dispatcher import Dispatcher

#: Why the package's compiled functions are not cached (the first function's error), or None.
uncached: str | None = None

# Only the functions of this project fall back; anything else keeps numba's error.
_PACKAGES = ("core.", "app.")
_numba_enable_caching = Dispatcher.enable_caching


def _enable_caching(dispatcher: Dispatcher) -> None:
    global uncached
    try:
        _numba_enable_caching(dispatcher)
    except RuntimeError as error:
        module = getattr(dispatcher.py_func, "__module__", "") or ""
        if "no locator available" not in str(error) or not module.startswith(_PACKAGES):
            raise
        dispatcher._cache = NullCache()  # what cache=False sets up
        if uncached is None:
            uncached = str(error)
            print(
                "note: numba cannot write its cache (no writable NUMBA_CACHE_DIR, __pycache__ or "
                "~/.cache/numba): compiling without it, so every run compiles again; set "
                "NUMBA_CACHE_DIR to a writable folder to keep the compiled solver",
                file=sys.stderr,
                flush=True,
            )


#: The folder of `core`, whose modules hold the package's compiled functions.
_FOLDER = Path(__file__).resolve().parent


@functools.cache
def package_stamp() -> str:
    """SHA-256 of the package's modules that hold compiled functions (``njit`` in their text) and
    of the modules of the package they import, transitively: a compiled function freezes the
    constants it reads from them (`core.layer_compiled` reads the panels' Gauss nodes)."""
    texts = {path.name: path.read_bytes() for path in _FOLDER.glob("*.py") if path.name != "jit_cache.py"}
    stamped = {name for name, text in texts.items() if b"njit" in text}
    pending = sorted(stamped)
    while pending:
        text = texts[pending.pop()]
        modules = _SUBMODULE.findall(text) + [
            m.strip() for names in _NAMES.findall(text) for m in names.split(b",")
        ]
        for module in modules:
            name = module.decode() + ".py"
            if name in texts and name not in stamped:
                stamped.add(name)
                pending.append(name)
    digest = hashlib.sha256()
    for name in sorted(stamped):
        digest.update(name.encode() + b"\0" + texts[name] + b"\0")
    return digest.hexdigest()


#: ``from core.X import ...`` and ``from core import X, Y``: the package's modules a module imports.
_SUBMODULE = re.compile(rb"^\s*from core\.(\w+) import", re.MULTILINE)
_NAMES = re.compile(rb"^\s*from core import ([\w, ]+)$", re.MULTILINE)


class _PackageLocator(_CacheLocator):
    """numba's own cache locator for a function of `core`, stamped with `package_stamp`."""

    def __init__(self, inner: _CacheLocator):
        self._inner = inner

    def ensure_cache_path(self):
        self._inner.ensure_cache_path()

    def get_cache_path(self):
        return self._inner.get_cache_path()

    def get_source_stamp(self):
        return package_stamp()

    def get_disambiguator(self):
        return self._inner.get_disambiguator()

    @classmethod
    def from_function(cls, py_func, py_file):
        if not (getattr(py_func, "__module__", "") or "").startswith("core."):
            return None
        for other in CacheImpl._locator_classes:
            if other is not cls:
                inner = other.from_function(py_func, py_file)
                if inner is not None:
                    return cls(inner)
        return None


def install() -> None:
    """Route `Dispatcher.enable_caching` through the fallback and put `_PackageLocator` first
    among numba's cache locators (idempotent)."""
    Dispatcher.enable_caching = _enable_caching
    if _PackageLocator not in CacheImpl._locator_classes:
        CacheImpl._locator_classes.insert(0, _PackageLocator)


install()
