"""core.boundary_integrals.compiled_integrals: the compiled boundary integrals equal the numpy ones;
never compiled unasked."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from support.paths import ROOT
from support.shapes import interior_points, near_boundary_points

import core
from app.studies.quality_suite import built_in_shapes
from core.boundary_integrals import cauchy_integrals, compiled_integrals, compiled_tree, poisson
from core.boundary_integrals.panels import curve_panels

SHAPES = built_in_shapes()


def both_paths(monkeypatch, function):
    """function() under compiled_integrals.mode "numpy", then "compiled", each with a fresh density solve."""
    results = []
    for mode in ("numpy", "compiled"):
        monkeypatch.setattr(compiled_integrals, "mode", mode)
        poisson.solved_densities.cache_clear()
        results.append(function())
    poisson.solved_densities.cache_clear()
    return results


@pytest.mark.parametrize("name", ["C-shape", "hook", "F polygon", "F polygon, clockwise"])
def test_the_compiled_layer_equals_the_numpy_one(name, monkeypatch):
    # Interior points, points down to 1e-6 of the diameter from the curve (next to corners too),
    # and points on it: the same values to rounding, and the same points found on the curve. The
    # clockwise cage checks the orientation's sign.
    points = SHAPES[name.removesuffix(", clockwise")]
    curve = core.ClosedBSpline(points[::-1] if name.endswith("clockwise") else points)
    on_curve = curve.evaluate(np.linspace(0, curve.n, 37, endpoint=False) + 0.013)[0]
    near = near_boundary_points(curve, 200, seed=5)[0]
    x = np.vstack([interior_points(curve, 200, seed=4), near, on_curve])

    def integrals():
        solution = poisson.densities(curve)
        return cauchy_integrals.cauchy_integrals(curve, solution.levels, x), core.basis_functions(curve, x)

    (numpy_rows, numpy_basis), (compiled_rows, compiled_basis) = both_paths(monkeypatch, integrals)
    # Each path solves for its own densities: their roundings differ most next to a sharp
    # corner, where the method's own error is ~1e-10 (measured 9.7e-12, F polygon).
    np.testing.assert_allclose(compiled_rows[0], numpy_rows[0], rtol=0, atol=5e-11)
    np.testing.assert_array_equal(compiled_rows[2], numpy_rows[2])
    assert numpy_rows[2][-37:].all()  # the points on the curve are found there
    np.testing.assert_allclose(compiled_basis, numpy_basis, rtol=0, atol=5e-11)


@pytest.mark.parametrize("name", ["C-shape", "F polygon"])
def test_the_compiled_layer_s_imaginary_parts_and_derivatives_equal_the_numpy_ones(name, monkeypatch):
    # Cauchy-Green takes the Cauchy integral's imaginary part, the gradients its z-derivative.
    from core.boundary_integrals import cauchy_green

    curve = core.ClosedBSpline(SHAPES[name])
    x = np.vstack([interior_points(curve, 150, seed=8), near_boundary_points(curve, 150, seed=9)[0]])

    def integrals():
        cauchy_green._levels.cache_clear()
        levels = poisson.densities(curve).levels
        return (
            cauchy_integrals.cauchy_integrals(curve, levels, x, imaginary=True),
            cauchy_integrals.cauchy_derivatives(curve, levels, x),
            core.basis_functions(curve, x, "cauchy-green"),
            core.basis_gradients(curve, x, "poisson"),
        )

    numpy_path, compiled_path = both_paths(monkeypatch, integrals)
    (real, imag, on_curve), derivative, green, gradients = numpy_path
    compiled_rows, compiled_derivative, compiled_green, compiled_gradients = (
        compiled_path
    )  # fmt: skip
    compiled_real, compiled_imag, compiled_on_curve = compiled_rows
    np.testing.assert_allclose(compiled_real, real, rtol=0, atol=5e-11)
    np.testing.assert_allclose(compiled_imag, imag, rtol=0, atol=5e-11)
    np.testing.assert_array_equal(compiled_on_curve, on_curve)
    np.testing.assert_allclose(compiled_green, green, rtol=0, atol=1e-12)  # no density solve
    # Derivatives grow as 1 / distance: compared relative to each point's largest. Their near rule
    # sums pieces' rules ~1/distance^2 apart in another order, on densities solved apart: measured
    # 1.3e-9 next to the F polygon's corners.
    scale = np.abs(derivative).max(axis=1, keepdims=True)
    np.testing.assert_allclose(compiled_derivative / scale, derivative / scale, rtol=0, atol=1e-8)
    scale = np.abs(gradients).max(axis=(1, 2), keepdims=True)
    np.testing.assert_allclose(compiled_gradients / scale, gradients / scale, rtol=0, atol=1e-8)


@pytest.mark.parametrize("layout", ["one point many times", "a line", "a cloud and a far cluster"])
def test_targets_sharing_a_box_get_their_own_decisions(layout, monkeypatch):
    # layer_rows decides for boxes of targets what it would decide for each: the same sums as
    # each target alone (a box of one), to rounding, however the targets lie (all equal, so
    # that no split separates them; on a line, so that boxes are flat; a cloud beside the curve
    # with a tight cluster elsewhere, so that boxes split down to their leaves).
    monkeypatch.setattr(compiled_integrals, "mode", "compiled")
    curve = core.ClosedBSpline(SHAPES["F polygon"])
    solution = poisson.densities(curve)
    rng = np.random.default_rng(11)
    if layout == "one point many times":
        x = np.repeat(interior_points(curve, 1, seed=3), 100, axis=0)
    elif layout == "a line":
        x = interior_points(curve, 300, seed=3)
        x[:, 1] = x[0, 1]
        x = x[curve.contains(x)]
    else:
        near = near_boundary_points(curve, 300, seed=6)[0]
        x = np.vstack([near, interior_points(curve, 1, seed=8) + rng.normal(scale=1e-6, size=(200, 2))])
    together = cauchy_integrals.cauchy_integrals(curve, solution.levels, x, imaginary=True)
    alone = [
        cauchy_integrals.cauchy_integrals(curve, solution.levels, point[None], imaginary=True) for point in x
    ]
    for part in (0, 1):
        each = np.concatenate([rows[part] for rows in alone])
        np.testing.assert_allclose(together[part], each, rtol=0, atol=1e-13 * np.abs(each).max())
    np.testing.assert_array_equal(together[2], np.concatenate([rows[2] for rows in alone]))


def test_a_box_s_decision_is_every_target_s_own():
    # _box_side answers FAR only if no target within `radius` of the centre is near the panel
    # (by layer_rows's per-target test), NEAR only if every one is: boxes of 1-50 targets at the
    # panels' reach and close-range boundaries, spreads from 1e-16 to 1e-1 of the diameter.
    curve = core.ClosedBSpline(SHAPES["F polygon"])
    tree = cauchy_integrals._panel_tree(curve, poisson.densities(curve).levels)
    rng = np.random.default_rng(12)
    close = np.sqrt(tree.close_squared)
    checked = {compiled_tree.FAR: 0, compiled_tree.NEAR: 0}
    for _ in range(3000):
        p = int(rng.integers(tree.centres.size))
        node = tree.node_z[p * 16 + int(rng.integers(16))]
        angle = np.exp(2j * np.pi * rng.random())
        edge = [tree.centres[p] + tree.reach[p] * angle, node + close[p] * angle][int(rng.integers(2))]
        spread = curve.diameter * 10.0 ** rng.uniform(-16, -1)
        z = edge + spread * (rng.normal(size=int(rng.integers(1, 51))) + 1j * rng.normal(size=1))
        centre = complex(0.5 * (z.real.min() + z.real.max()), 0.5 * (z.imag.min() + z.imag.max()))
        radius = np.abs(z - centre).max()
        side = compiled_tree._box_side(
            p, centre, radius, tree.node_z, tree.centres, tree.reach, tree.close_squared
        )
        nodes = tree.node_z[p * 16 : (p + 1) * 16]
        square = np.abs(nodes[None, :] - z[:, None]) ** 2
        near = (np.abs(z - tree.centres[p]) < tree.reach[p]) & (square.min(axis=1) < tree.close_squared[p])
        if side == compiled_tree.FAR:
            assert not near.any()
        elif side == compiled_tree.NEAR:
            assert near.all()
        checked[side] = checked.get(side, 0) + 1
    assert checked[compiled_tree.FAR] > 100 and checked[compiled_tree.NEAR] > 100


def test_boxes_take_any_targets():
    # No targets, one, all equal, and non-finite ones (which the callers refuse first): every
    # target in exactly one box, none outside the grid.
    for targets in (
        np.zeros(0, dtype=complex), np.array([0.5 + 0.5j]), np.full(100, 1.0 + 2.0j),
        np.array([0.5 + 0.5j, np.nan + 0.3j, complex(0.4, np.inf), complex(-np.inf, 0.2), 0.7 + 0.1j]),
        np.array([complex(np.nan, np.nan), complex(np.inf, -np.inf)]),
    ):  # fmt: skip
        order, start = compiled_tree.target_boxes(targets, compiled_tree.BOX)
        assert np.array_equal(np.sort(order), np.arange(targets.size))
        assert start[0] == 0 and start[-1] == targets.size and np.all(np.diff(start) >= 0)


@pytest.mark.parametrize("power", [1, 2])
def test_the_compiled_near_rule_equals_the_numpy_one(power, monkeypatch):
    # Targets at 1e-9 .. 1e-1 of a panel's length from it, one exactly on a node: the adaptive
    # rule's weights for the Cauchy integral and its derivative, and its on-curve flags.
    curve = core.ClosedBSpline(SHAPES["F polygon"])
    panels = curve_panels(curve)
    rng = np.random.default_rng(7)
    panel = rng.integers(0, panels.count, 300)
    node = panel * 16 + rng.integers(0, 16, panel.size)
    normal = 1j * panels.dz[node] / np.abs(panels.dz[node])
    targets = panels.z[node] + normal * panels.lengths[panel] * 10 ** rng.uniform(-9, -1, panel.size)
    targets[0] = panels.z[node[0]]

    def weights():
        return cauchy_integrals.adaptive_weights(curve, panels, targets, panel, power)

    (numpy_weights, numpy_touching), (compiled_weights, compiled_touching) = both_paths(monkeypatch, weights)
    np.testing.assert_array_equal(compiled_touching, numpy_touching)
    assert numpy_touching[0]
    scale = np.abs(numpy_weights[~numpy_touching]).max(axis=1, keepdims=True)
    tolerance = 1e-13 if power == 1 else 1e-12
    compiled_weights, numpy_weights = compiled_weights[~compiled_touching], numpy_weights[~numpy_touching]
    np.testing.assert_allclose(compiled_weights / scale, numpy_weights / scale, rtol=0, atol=tolerance)


def test_load_compiled_brings_in_every_compiled_boundary_integral():
    # The bench says "runs as numpy batches" when this is False: each of the eight must be called
    # by it, in a process that has called none of them before (a solve of a cage without thin
    # parts calls neither the near-field rule on its own nor the Nyström matrix rows).
    script = (
        "from core.boundary_integrals import compiled_integrals as c, poisson; "
        "c.mode = 'compiled'; print(poisson.load_compiled())"
    )
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=600, cwd=ROOT
    )
    assert result.stdout.split() == ["True"], result.stderr


def test_loaded_never_compiles(monkeypatch):
    # "auto" takes the compiled path only where machine code exists: for argument types that
    # were never compiled it answers False and compiles nothing.
    monkeypatch.setattr(compiled_integrals, "mode", "auto")
    dispatcher = compiled_integrals.adaptive_pairs
    before = len(dispatcher.overloads)
    strange = (
        np.zeros((1, 3, 2), dtype=np.float32), np.zeros((1, 2), dtype=np.float32), np.zeros(1, np.complex64),
        np.zeros(1, dtype=np.int32), 1, 0.0, 0.5, 60, np.zeros((1, 16, 16), dtype=np.float32),
    )  # fmt: skip
    assert not compiled_integrals.loaded(dispatcher, *strange)
    assert len(dispatcher.overloads) == before
    monkeypatch.setattr(compiled_integrals, "mode", "numpy")
    assert not compiled_integrals.loaded(dispatcher)
    monkeypatch.setattr(compiled_integrals, "mode", "compiled")
    assert compiled_integrals.loaded(dispatcher)


def test_the_cache_is_read_once_the_work_repays_it(monkeypatch):
    # A process reads numba's cache (~0.2 s) only after LOAD_AFTER_POINTS points, or once it
    # has read it before; never for a dispatcher whose entry failed to load.
    class Fresh:
        overloads = {}

    monkeypatch.setattr(compiled_integrals, "mode", "auto")
    monkeypatch.setattr(compiled_integrals, "_read", False)
    monkeypatch.setattr(compiled_integrals, "_points", 0)
    monkeypatch.setattr(compiled_integrals, "_unreadable", set())
    fresh = Fresh()
    assert not compiled_integrals.worth_trying(fresh, compiled_integrals.LOAD_AFTER_POINTS - 1)
    assert compiled_integrals.worth_trying(fresh, 1)  # the points add up
    monkeypatch.setattr(compiled_integrals, "_points", 0)
    assert not compiled_integrals.worth_trying(fresh)
    compiled_integrals.allow_reading()
    assert compiled_integrals.worth_trying(fresh)
    compiled_integrals._unreadable.add(fresh)
    assert not compiled_integrals.worth_trying(fresh)


def test_run_compiled_builds_its_arguments_only_where_it_calls(monkeypatch):
    # mode "numpy": None, and the arguments are never built; "compiled": the function's own result,
    # or for a loop in shares its arguments, the outputs written; arguments that say None: None.
    built = []

    def arguments():
        built.append(True)
        return np.array([[1.0, 2.0], [0.0, 1.0]]), np.array([[3.0], [4.0]]), np.full((2, 1), np.nan)

    monkeypatch.setattr(compiled_integrals, "mode", "numpy")
    assert compiled_integrals.run_compiled(compiled_integrals.rows_product, arguments, items=2) is None
    assert built == []
    monkeypatch.setattr(compiled_integrals, "mode", "compiled")
    found = compiled_integrals.run_compiled(compiled_integrals.rows_product, arguments, items=2)
    np.testing.assert_array_equal(found[2], [[11.0], [4.0]])
    assert built == [True]
    assert compiled_integrals.run_compiled(compiled_integrals.panel_geometry, lambda: None) is None


def test_a_damaged_cache_entry_falls_back_to_numpy_for_good(monkeypatch):
    # A truncated .nbc file makes numba's loader raise: the default kernel still answers, with
    # numpy, and the entry is not tried again.
    import pickle

    monkeypatch.setattr(compiled_integrals, "mode", "auto")
    monkeypatch.setattr(compiled_integrals, "_unreadable", set())
    dispatcher = compiled_integrals.adaptive_pairs
    attempts = []

    def damaged(*arguments):
        attempts.append(arguments)
        raise pickle.UnpicklingError("pickle data was truncated")

    monkeypatch.setattr(dispatcher, "overloads", {})
    monkeypatch.setattr(dispatcher._cache, "load_overload", damaged)
    curve = core.ClosedBSpline(SHAPES["C-shape"])
    panels = curve_panels(curve)
    targets, panel = panels.z[:3] + 1e-3, np.array([1, 1, 1])
    pieces = curve.piecewise_polynomial().coefficients
    arguments = (
        pieces,
        panels.bounds,
        targets,
        panel,
        1,
        0.0,
    )
    assert not compiled_integrals.loaded(dispatcher, *arguments)
    assert not compiled_integrals.loaded(dispatcher, *arguments)
    assert len(attempts) == 1 and not compiled_integrals.worth_trying(dispatcher)
    monkeypatch.setattr(compiled_integrals, "_read", True)
    weights, _ = cauchy_integrals.adaptive_weights(curve, panels, targets, panel)  # numpy
    assert np.isfinite(weights).all() and len(attempts) == 1


def test_without_numba_s_cache_the_default_kernel_runs_as_numpy_without_compiling(tmp_path):
    # An empty numba cache (another CPU model or numba version than the install's): nothing is
    # compiled, load_compiled says so, and the basis is still exact.
    script = (
        "import time, numpy as np, core\n"
        "from core.boundary_integrals import compiled_integrals as c, compiled_tree, poisson\n"
        "start = time.perf_counter(); found = poisson.load_compiled()\n"
        "square = core.ClosedBSpline(np.array([[0.0, 0], [2, 0], [2, 1], [0, 1]]))\n"
        "x = np.random.default_rng(2).uniform((0.7, 0.35), (1.3, 0.65), (c.LOAD_AFTER_POINTS + 10, 2))\n"
        "G = core.basis_functions(square, x)\n"
        "print(found, len(c.adaptive_pairs.overloads), len(compiled_tree.layer_rows.overloads),"
        " np.abs(G @ square.control_points - x).max(), time.perf_counter() - start)\n"
    )
    environment = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path), PYTHONPATH=str(ROOT))
    command = [sys.executable, "-c", script]
    result = subprocess.run(command, capture_output=True, text=True, timeout=300, env=environment, cwd=ROOT)
    assert result.returncode == 0, result.stderr
    found, adaptive, rows, error, seconds = result.stdout.split()
    assert (found, adaptive, rows) == ("False", "0", "0")
    assert float(error) < 1e-10  # the cage is 2 x 1
    assert float(seconds) < 60  # numba compiling both would take ~7 s more; numpy alone ~2 s
    assert not list(tmp_path.glob("**/*.nbi"))  # nothing was compiled into the cache


def test_the_signature_cache_keys_arguments_as_numba_types_them():
    # `loaded` keeps numba's signature per `_argument_key`: arguments numba types apart must
    # have different keys, and kinds it does not know are not cached at all (None).
    key = compiled_integrals._argument_key
    assert key(np.zeros(3)) == key(np.ones(3)) != key(np.zeros(3, dtype=np.float32))
    assert key(np.zeros((3, 2))[:, 0]) != key(np.zeros(3))  # strided: numba's layout "A"
    readonly = np.zeros(3)
    readonly.setflags(write=False)
    assert key(readonly) != key(np.zeros(3))
    records = key(np.zeros(1, dtype=[("a", "f8"), ("b", "f8")]))
    assert records != key(np.zeros(1, dtype=[("c", "i8"), ("d", "i8")]))
    assert key(1) == key(2) != key(1.0) and key(True) != key(1)
    assert key(2**63) is None and key([1.0]) is None and key((np.zeros(2), [1])) is None


@pytest.mark.parametrize("mode", ["numpy", "compiled"])
@pytest.mark.parametrize("name", ["blob", "hook"])
def test_the_near_rule_integrates_a_constant_density_exactly(name, mode, monkeypatch):
    # For φ = 1 the integrals have closed forms on the panel [a, b]: ∫ dτ / (τ - z) = log((p(b) - z)
    # / (p(a) - z)) (the imaginary part up to 2π, the winding) and ∫ dτ / (τ - z)^2 = 1 / (p(a) - z)
    # - 1 / (p(b) - z).  The product rule is exact for the interpolant, so its weights sum to them
    # at any distance, 1e-10 of a panel's length to three lengths, on either side of the curve.
    # (Not next to sharp corners: panels 1e-8 of the diameter long there have their ends and
    # nodes in coordinates good to ~1e-8 of their length, which both sides of this test inherit.)
    monkeypatch.setattr(compiled_integrals, "mode", mode)
    from core.curves import examples

    points = examples.blob() if name == "blob" else SHAPES[name]
    curve = core.ClosedBSpline(points - points.mean(axis=0))
    panels = curve_panels(curve)
    rng = np.random.default_rng(11)
    panel = rng.integers(0, panels.count, 2000)
    node = panel * 16 + rng.integers(0, 16, panel.size)
    normal = 1j * panels.dz[node] / np.abs(panels.dz[node])
    distance = panels.lengths[panel] * 10 ** rng.uniform(-10, np.log10(3.0), panel.size)
    targets = panels.z[node] + normal * distance * rng.choice([-1.0, 1.0], panel.size)
    low, high = (curve(panels.bounds[panel, k]) @ np.array([1.0, 1j]) for k in (0, 1))
    logarithm = np.log((high - targets) / (low - targets))
    for power, exact in ((1, logarithm), (2, 1.0 / (low - targets) - 1.0 / (high - targets))):
        weights, touching = cauchy_integrals.adaptive_weights(
            curve, panels, targets, panel, power, on_curve=0.0
        )
        assert not touching.any()
        error = weights.sum(axis=1) - exact
        if power == 1:  # the winding: a multiple of 2πi
            error = error.real + 1j * (error.imag - 2.0 * np.pi * np.round(error.imag / (2.0 * np.pi)))
        assert (np.abs(error) / np.abs(weights).max(axis=1)).max() <= 1e-11


def test_balanced_sequence_gives_each_thread_an_equal_share_of_the_knot_blocks(monkeypatch):
    monkeypatch.setattr("numba.config.NUMBA_NUM_THREADS", 2)
    costs = np.array([8, 8, 10, 10, 8, 10, 8, 8, 8, 8, 8, 10], dtype=float) ** 3  # the bench blob's
    sequence = compiled_integrals.balanced_sequence(costs)
    assert sorted(sequence.tolist()) == list(range(costs.size))
    assert costs[sequence[:6]].sum() == costs[sequence[6:]].sum() == costs.sum() / 2
    assert compiled_integrals.balanced_sequence(np.zeros(0)).size == 0


@pytest.mark.parametrize("name", ["C-shape", "F polygon"])
def test_the_compiled_panel_geometry_equals_the_numpy_one(name, monkeypatch):
    # Panels across every span, split and graded ones: the same nodes, weights and circles.
    from core.boundary_integrals import panels as panel_module

    curve = core.ClosedBSpline(SHAPES[name])
    bounds = panel_module.curve_panels(curve).bounds

    def geometry():
        return panel_module.panels_on_intervals(curve, bounds)

    numpy_panels, compiled_panels = both_paths(monkeypatch, geometry)
    scale = curve.diameter
    for field in ("t", "weights", "z", "dz", "d2z", "centres", "radii", "lengths"):
        a, b = getattr(numpy_panels, field), getattr(compiled_panels, field)
        size = scale if field in ("z", "centres", "radii") else np.abs(a).max()
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-15 * size, err_msg=field)


def test_the_compiled_interpolation_rows_equal_the_numpy_ones(monkeypatch):
    # Random parameters, the nodes themselves (unit rows) and the ends of the panel.
    from core.boundary_integrals import gauss_legendre
    from core.boundary_integrals import panels as panel_module

    nodes = gauss_legendre.NODES
    u = np.concatenate([np.random.default_rng(6).uniform(-1.0, 1.0, 500), nodes, [-1.0, 1.0, 1e-300]])
    assert u.size >= panel_module.COMPILED_ROWS

    def rows():
        return panel_module.interpolation_matrix(u)

    numpy_rows, compiled_rows = both_paths(monkeypatch, rows)
    np.testing.assert_allclose(compiled_rows, numpy_rows, rtol=0, atol=2e-15 * np.abs(numpy_rows).max())
    np.testing.assert_array_equal(compiled_rows[500 : 500 + nodes.size], np.eye(nodes.size))
    np.testing.assert_allclose(compiled_rows.sum(axis=1), 1.0, rtol=0, atol=1e-15)
    # Values at the nodes come back: a polynomial of degree < ORDER is interpolated exactly.
    values = nodes**15 - 3.0 * nodes**4
    np.testing.assert_allclose(compiled_rows @ values, u**15 - 3.0 * u**4, rtol=0, atol=1e-13)


@pytest.mark.parametrize("name", ["C-shape", "hook", "F polygon"])
def test_the_compiled_gaps_equal_the_numpy_ones(name, monkeypatch):
    # The distances across thin parts and past corners that split the coarse panels: the same but
    # for the last bit of a hypot (numpy's and the C library's).
    from core.boundary_integrals import panels as panel_module

    curve = core.ClosedBSpline(SHAPES[name])
    coarse = panel_module.coarse_panels(curve)
    corners = panel_module.sharp_corners(curve).astype(float)

    def gaps():
        return panel_module.gaps(coarse, corners)

    numpy_gaps, compiled_gaps = both_paths(monkeypatch, gaps)
    assert np.isfinite(numpy_gaps).any()
    np.testing.assert_array_equal(np.isinf(compiled_gaps), np.isinf(numpy_gaps))
    finite = np.isfinite(numpy_gaps)
    np.testing.assert_allclose(compiled_gaps[finite], numpy_gaps[finite], rtol=1e-15, atol=0)


@pytest.mark.parametrize("name", ["C-shape", "F polygon"])
def test_the_compiled_near_pairs_equal_the_numpy_ones(name, monkeypatch):
    # The density solve's coarse nodes against its coarse panels, and points down to 1e-6 of the
    # diameter from the curve: the same pairs in the same order.
    from core.boundary_integrals import panels as panel_module

    curve = core.ClosedBSpline(SHAPES[name])
    coarse = panel_module.coarse_panels(curve)
    x = near_boundary_points(curve, 300, seed=3)[0]
    for targets in (coarse.z, x[:, 0] + 1j * x[:, 1]):
        (numpy_target, numpy_panel), (target, panel) = both_paths(
            monkeypatch, lambda targets=targets: cauchy_integrals.near_pairs(coarse, targets, curve.diameter)
        )
        assert numpy_target.size > coarse.count
        np.testing.assert_array_equal(target, numpy_target)
        np.testing.assert_array_equal(panel, numpy_panel)
