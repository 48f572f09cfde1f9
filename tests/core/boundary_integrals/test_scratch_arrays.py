"""Scratch arrays kept per thread (core.boundary_integrals.scratch_arrays)."""

from __future__ import annotations

import threading

import numpy as np

from core.boundary_integrals import scratch_arrays


def test_a_name_keeps_its_memory_and_other_names_and_threads_get_their_own():
    first = scratch_arrays.scratch("test a", (30, 40))
    again = scratch_arrays.scratch("test a", (20, 10))  # smaller: the same memory
    other = scratch_arrays.scratch("test b", (30, 40))
    assert first.shape == (30, 40) and again.shape == (20, 10)
    assert np.shares_memory(first, again) and not np.shares_memory(first, other)
    grown = scratch_arrays.scratch("test a", (50, 50))  # larger: new memory, kept from now on
    assert not np.shares_memory(first, grown)
    assert np.shares_memory(grown, scratch_arrays.scratch("test a", (7,)))
    elsewhere = []
    thread = threading.Thread(target=lambda: elsewhere.append(scratch_arrays.scratch("test a", (50, 50))))
    thread.start()
    thread.join()
    assert not np.shares_memory(grown, elsewhere[0])


def test_an_array_over_the_limit_is_not_kept(monkeypatch):
    monkeypatch.setattr(scratch_arrays, "KEPT", 8 * 100)
    big = scratch_arrays.scratch("test c", (11, 10))
    assert big.shape == (11, 10) and not np.shares_memory(big, scratch_arrays.scratch("test c", (11, 10)))
