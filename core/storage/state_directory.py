"""The application's state directory: what it keeps between runs that is not a cache (viewer
sessions, the cache's key)."""

from __future__ import annotations

import os
from pathlib import Path

STATE_VARIABLE = "TRANSFINITE_STATE_DIR"


def state_directory() -> Path:
    """``$TRANSFINITE_STATE_DIR``, or ``transfinite-warp`` in ``$XDG_STATE_HOME`` (``~/.local/state``
    if that is unset or, as the XDG base directory specification says, not an absolute path)."""
    configured = os.environ.get(STATE_VARIABLE)
    if configured:
        return Path(configured).expanduser()
    base = Path(os.environ.get("XDG_STATE_HOME", ""))
    if not base.is_absolute():
        base = Path.home() / ".local" / "state"
    return base / "transfinite-warp"
