"""numba's on-disk cache, or an uncached compilation where no cache folder can be written.

``@njit(cache=True)`` looks for a writable folder when a function is defined (at
import): ``NUMBA_CACHE_DIR``, else ``__pycache__`` beside the source, else
numba's user-wide cache (``$XDG_CACHE_HOME/numba``, ``~/.cache/numba``).  Where
none can be written (a read-only install with an unwritable home) numba raises
``cannot cache function '_slab': no locator available`` and the package would
not import.  Imported first by `core`, this module makes such functions of the
package compile without the cache instead, and says so in one line on stderr:
everything works, only each run compiles again.
"""

from __future__ import annotations

import sys

from numba.core.caching import NullCache
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


def install() -> None:
    """Route `Dispatcher.enable_caching` through the fallback (idempotent)."""
    Dispatcher.enable_caching = _enable_caching


install()
