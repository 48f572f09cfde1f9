"""core.blas_threads: OpenBLAS's idle threads spin briefly, set before numpy loads OpenBLAS."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from core.blas_threads import IDLE_SPIN

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.parametrize("first", ["core", "app.cli"])
def test_the_idle_spin_is_set_before_numpy_loads(first):
    # app.cli loads numpy before core, so app sets the same value itself; a user's own setting stays.
    script = f"import sys, os, {first}; print(os.environ['OPENBLAS_THREAD_TIMEOUT'])"
    environment = {k: v for k, v in os.environ.items() if k != "OPENBLAS_THREAD_TIMEOUT"}
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, env=environment, cwd=ROOT
    )
    assert result.stdout.split() == [str(IDLE_SPIN)], result.stderr
    environment["OPENBLAS_THREAD_TIMEOUT"] = "7"
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, env=environment, cwd=ROOT
    )
    assert result.stdout.split() == ["7"], result.stderr
