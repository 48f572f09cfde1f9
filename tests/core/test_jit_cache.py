"""`core.jit_cache.compile_note`: a numba compilation (not a cache load) says so once a process,
as the mesher's first use does where the install's cache does not apply (`core.triangulate`)."""

from __future__ import annotations

import numba
import pytest

from core import jit_cache
from core.meshes import triangulation


def fresh_function(module: str):
    """A new compiled function (nothing cached: `cache=False`) that numba sees as `module`'s."""

    def add_one(x):
        return x + 1

    add_one.__module__ = module
    return numba.njit(cache=False)(add_one)


@pytest.fixture
def nothing_noted(monkeypatch):
    monkeypatch.setattr(jit_cache, "_noted", set())


def test_the_first_compilation_under_the_prefix_is_said_once(nothing_noted, capsys):
    with jit_cache.compile_note("core.meshes.", triangulation.COMPILING_NOTE):
        assert fresh_function("core.meshes.example")(1) == 2
        fresh_function("core.meshes.other")(1)
    with jit_cache.compile_note("core.meshes.", triangulation.COMPILING_NOTE):
        fresh_function("core.meshes.third")(1)
    assert capsys.readouterr().err == triangulation.COMPILING_NOTE + "\n"


def test_other_modules_and_compilations_outside_the_block_say_nothing(nothing_noted, capsys):
    with jit_cache.compile_note("core.meshes.", "compiling"):
        fresh_function("core.newton.example")(1)
    fresh_function("core.meshes.example")(1)
    assert capsys.readouterr().err == ""
