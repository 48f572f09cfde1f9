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
(`core.newton.gradient_solver` and `core.curves.closest_point` call `core.newton.solver`): after an edit of
the callee alone the caller's cache would still run the old code.  Here every compiled
function of the package is stamped with the content of all of the package's modules that
hold compiled functions (`_PackageLocator`), so any edit of one recompiles them all.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import re
import sys
from pathlib import Path

from numba.core import event
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
    constants it reads from them (`core.boundary_integrals.compiled_integrals` reads the Gauss
    nodes of `core.boundary_integrals.gauss_legendre`)."""
    texts = {
        _dotted(path): path.read_bytes()
        for path in sorted(_FOLDER.rglob("*.py"))
        if path.name != "__init__.py"
    }
    stamped = {name for name, text in texts.items() if b"njit" in text}
    pending = sorted(stamped)
    while pending:
        for module in imported_modules(texts[pending.pop()]):
            if module in texts and module not in stamped:
                stamped.add(module)
                pending.append(module)
    digest = hashlib.sha256()
    for name in sorted(stamped):
        digest.update(name.encode() + b"\0" + texts[name] + b"\0")
    return digest.hexdigest()


def imported_modules(text: bytes) -> set[str]:
    """The modules of `core` that source `text` may import, as names relative to `core`
    (``newton.solver``): ``from core.X import ...`` gives X, ``from core.X import Y`` also X.Y."""
    modules = set()
    for base, names in _FROM.findall(text):
        base = base.decode().lstrip(".")
        names = re.sub(rb"#[^\n]*", b"", names)
        modules.add(base)
        modules |= {f"{base}.{name.decode()}".lstrip(".") for name in _NAME.findall(names)}
    return modules


def _dotted(path: Path) -> str:
    """The name of the module at `path` relative to `core`: ``newton/solver.py`` -> ``newton.solver``."""
    return ".".join(path.relative_to(_FOLDER).with_suffix("").parts)


#: ``from core.X import names`` (names on one line or in parentheses) and ``from core import X, Y``.
_FROM = re.compile(rb"^\s*from core((?:\.\w+)*) import (\([^)]*\)|[^\n]*)", re.MULTILINE)
#: An imported name, without its ``as`` alias.
_NAME = re.compile(rb"(\w+)(?:\s+as\s+\w+)?")


class _PackageLocator(_CacheLocator):
    """numba's own cache locator for a function of `core`, stamped with `package_stamp`."""

    def __init__(self, inner: _CacheLocator):
        self._inner = inner
        # numba's warning that a function cannot be cached (it uses dynamic globals) names the file.
        self._py_file = inner._py_file

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


class _CompileNote(event.Listener):
    """Prints `note` on stderr at the first compilation of a function of a module under `prefix`."""

    def __init__(self, prefix: str, note: str):
        self.prefix, self.note = prefix, note

    def on_start(self, data: event.Event) -> None:
        dispatcher = data.data.get("dispatcher") if isinstance(data.data, dict) else None
        module = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
        if module.startswith(self.prefix) and self.note not in _noted:
            _noted.add(self.note)
            print(self.note, file=sys.stderr, flush=True)

    def on_end(self, data: event.Event) -> None:
        pass


#: The notes already printed in this process (each at most once).
_noted: set[str] = set()


@contextlib.contextmanager
def compile_note(prefix: str, note: str):
    """Within the block, the first time numba compiles a function of a module whose name starts
    with `prefix` (a compilation, not a load from the cache: where the cache does not apply),
    `note` goes to stderr, once per process, so that a wait of seconds is said."""
    with event.install_listener("numba:compile", _CompileNote(prefix, note)):
        yield


def install() -> None:
    """Route `Dispatcher.enable_caching` through the fallback and put `_PackageLocator` first
    among numba's cache locators (idempotent)."""
    Dispatcher.enable_caching = _enable_caching
    if _PackageLocator not in CacheImpl._locator_classes:
        CacheImpl._locator_classes.insert(0, _PackageLocator)


install()
