"""Tests of core.mesh_basis and core.cache: basis functions at mesh vertices, cached on disk."""

import os
import warnings

import numpy as np
import pytest
from conftest import wavy_star as starfish

import core
from core import cache as disk_cache
from core import mesh_basis
from core.harmonic import harmonic_basis
from core.mesh import triangulate
from core.mesh_basis import MESH_ONLY_KERNELS, mesh_basis_functions
from core.pgw import pgw_basis


@pytest.fixture(autouse=True)
def cache_directory(tmp_path, monkeypatch):
    directory = tmp_path / "cache"
    monkeypatch.setenv("TRANSFINITE_CACHE_DIR", str(directory))
    return directory


@pytest.fixture(scope="module")
def setup():
    curve = core.ClosedBSpline(starfish())
    return curve, triangulate(curve, max_edge=0.25)


KERNEL_CASES = [
    ("harmonic", {}),
    ("pgw", {"angles": 64}),
    ("harmonic-like", {}),
    ("pseudo-harmonic", {}),
]


# ---------------------------------------------------------------- properties


@pytest.mark.parametrize(("kernel", "params"), KERNEL_CASES)
def test_boundary_rows_are_exactly_the_b_spline_basis(setup, kernel, params):
    curve, mesh = setup
    basis = mesh_basis_functions(curve, mesh, kernel=kernel, cache=False, **params)
    assert basis.shape == (mesh.vertices.shape[0], curve.n)
    np.testing.assert_array_equal(basis[mesh.boundary], curve.basis_matrix(mesh.boundary_parameters))


@pytest.mark.parametrize(("kernel", "params"), KERNEL_CASES)
def test_partition_of_unity_and_linear_precision(setup, kernel, params):
    curve, mesh = setup
    basis = mesh_basis_functions(curve, mesh, kernel=kernel, cache=False, **params)
    np.testing.assert_allclose(basis.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    # Exact (rounding) for harmonic and pgw, the Newton tolerance for the others.
    tolerance = 1e-9 * curve.diameter
    np.testing.assert_allclose(basis @ curve.control_points, mesh.vertices, rtol=0, atol=tolerance)


@pytest.mark.parametrize(("kernel", "params"), KERNEL_CASES)
def test_an_affine_cage_move_moves_the_mesh_affinely(setup, kernel, params):
    curve, mesh = setup
    basis = mesh_basis_functions(curve, mesh, kernel=kernel, cache=False, **params)
    matrix = np.array([[1.3, 0.4], [-0.2, 0.8]])
    shift = np.array([10.0, -3.0])
    target = curve.control_points @ matrix.T + shift
    np.testing.assert_allclose(basis @ target, mesh.vertices @ matrix.T + shift, rtol=0, atol=1e-8)


def test_harmonic_kernel_is_the_harmonic_basis(setup):
    curve, mesh = setup
    np.testing.assert_array_equal(
        mesh_basis_functions(curve, mesh, kernel="harmonic", cache=False), harmonic_basis(curve, mesh)
    )


def test_pgw_and_point_kernels_give_their_interior_rows(setup):
    curve, mesh = setup
    inside = mesh.vertices[mesh.interior]
    pgw = mesh_basis_functions(curve, mesh, kernel="pgw", samples_per_segment=10, cache=False)
    np.testing.assert_array_equal(pgw[mesh.interior], pgw_basis(curve, inside, samples_per_segment=10))
    from core.basis import basis_functions

    power = mesh_basis_functions(
        curve, mesh, kernel="power", cache=False, power=2.0, shift="mean", samples_per_segment=50
    )
    np.testing.assert_array_equal(
        power[mesh.interior],
        basis_functions(curve, inside, "power", samples_per_segment=50, power=2.0, shift="mean"),
    )


def test_mesh_only_kernels():
    assert MESH_ONLY_KERNELS == ("pgw", "harmonic")


# ---------------------------------------------------------------- cache


def test_second_call_reads_the_cache(setup, cache_directory, monkeypatch):
    curve, mesh = setup
    first = mesh_basis_functions(curve, mesh, kernel="harmonic")
    files = list(cache_directory.glob("*.npy"))
    assert len(files) == 1

    def fail(*args):
        raise AssertionError("recomputed instead of reading the cache")

    monkeypatch.setattr(mesh_basis, "_compute", fail)
    np.testing.assert_array_equal(mesh_basis_functions(curve, mesh, kernel="harmonic"), first)


def test_cache_false_neither_reads_nor_writes(setup, cache_directory):
    curve, mesh = setup
    mesh_basis_functions(curve, mesh, kernel="harmonic", cache=False)
    assert not cache_directory.exists() or not list(cache_directory.iterdir())


def test_keys_depend_on_everything_that_changes_the_result(setup, cache_directory):
    curve, mesh = setup
    mesh_basis_functions(curve, mesh, kernel="pgw", angles=16)
    mesh_basis_functions(curve, mesh, kernel="pgw", angles=32)
    mesh_basis_functions(curve, mesh, kernel="pgw", angles=16, samples_per_segment=50)
    mesh_basis_functions(curve, mesh, kernel="harmonic")
    assert len(list(cache_directory.glob("*.npy"))) == 4
    mesh_basis_functions(curve, mesh, kernel="pgw", angles=np.int64(16))  # same key as angles=16
    assert len(list(cache_directory.glob("*.npy"))) == 4


def test_cache_key_changes_with_each_input(setup):
    curve, mesh = setup
    arguments = dict(
        control_points=curve.control_points,
        vertices=mesh.vertices,
        triangles=mesh.triangles,
        boundary=mesh.boundary,
        boundary_parameters=mesh.boundary_parameters,
        kernel="power",
        samples_per_segment=100,
        params={"power": 2.0, "shift": "mean"},
    )
    key = disk_cache.cache_key(**arguments)
    assert len(key) == 64
    assert disk_cache.cache_key(**arguments) == key
    assert disk_cache.cache_key(**(arguments | {"params": {"shift": "mean", "power": 2.0}})) == key
    changes = {
        "control_points": curve.control_points * 1.000001,
        "vertices": mesh.vertices + 1e-12,
        "triangles": mesh.triangles[:, [1, 2, 0]],
        "boundary_parameters": mesh.boundary_parameters + 1e-12,
        "kernel": "harmonic-like",
        "samples_per_segment": 101,
        "params": {"power": 3.0, "shift": "mean"},
    }
    for name, value in changes.items():
        assert disk_cache.cache_key(**(arguments | {name: value})) != key, name


@pytest.mark.parametrize(
    "content",
    [b"", b"not a numpy file", b"\x93NUMPY\x01\x00garbage", b"PK\x03\x04 not a zip either"],
)
def test_a_corrupt_cache_file_is_recomputed(setup, cache_directory, content):
    curve, mesh = setup
    expected = mesh_basis_functions(curve, mesh, kernel="harmonic")
    (path,) = cache_directory.glob("*.npy")
    path.write_bytes(content)
    np.testing.assert_array_equal(mesh_basis_functions(curve, mesh, kernel="harmonic"), expected)
    np.testing.assert_array_equal(np.load(path), expected)  # rewritten


def test_a_cache_file_of_the_wrong_shape_or_values_is_recomputed(setup, cache_directory):
    curve, mesh = setup
    expected = mesh_basis_functions(curve, mesh, kernel="harmonic")
    (path,) = cache_directory.glob("*.npy")
    for wrong in (np.zeros((3, curve.n)), np.full(expected.shape, np.nan), expected.astype(np.float32)):
        np.save(path, wrong)
        np.testing.assert_array_equal(mesh_basis_functions(curve, mesh, kernel="harmonic"), expected)


def test_writes_are_atomic_and_leave_no_temporary_files(setup, cache_directory):
    curve, mesh = setup
    mesh_basis_functions(curve, mesh, kernel="harmonic")
    mesh_basis_functions(curve, mesh, kernel="pgw", angles=8)
    names = sorted(os.listdir(cache_directory))
    assert len(names) == 2 and all(name.endswith(".npy") and not name.startswith(".") for name in names)


def test_an_unwritable_cache_directory_warns_but_still_returns(setup, tmp_path, monkeypatch):
    curve, mesh = setup
    blocker = tmp_path / "a-file"
    blocker.write_text("not a directory")
    monkeypatch.setenv("TRANSFINITE_CACHE_DIR", str(blocker / "cache"))
    with pytest.warns(RuntimeWarning, match="could not write the basis-function cache"):
        basis = mesh_basis_functions(curve, mesh, kernel="harmonic")
    np.testing.assert_array_equal(basis, harmonic_basis(curve, mesh))


def test_default_cache_directory(monkeypatch, tmp_path):
    monkeypatch.delenv("TRANSFINITE_CACHE_DIR", raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    assert disk_cache.cache_directory() == disk_cache.Path.home() / ".cache" / "transfinite-warp"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/cache")  # ignored, as the XDG specification says
    assert disk_cache.cache_directory() == disk_cache.Path.home() / ".cache" / "transfinite-warp"
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert disk_cache.cache_directory() == tmp_path / "transfinite-warp"
    monkeypatch.setenv("TRANSFINITE_CACHE_DIR", str(tmp_path / "mine"))
    assert disk_cache.cache_directory() == tmp_path / "mine"


# ---------------------------------------------------------------- progress


@pytest.mark.parametrize(("kernel", "params"), KERNEL_CASES)
def test_progress_ends_at_one(setup, kernel, params):
    curve, mesh = setup
    seen = []
    mesh_basis_functions(curve, mesh, kernel=kernel, progress=seen.append, **params)
    assert seen and seen[-1] == 1.0 and seen == sorted(seen) and 0.0 <= seen[0]
    cached = []
    mesh_basis_functions(curve, mesh, kernel=kernel, progress=cached.append, **params)
    assert cached == [1.0]


# ---------------------------------------------------------------- errors


def test_unknown_kernel_lists_the_valid_names(setup):
    curve, mesh = setup
    with pytest.raises(ValueError, match="unknown kernel 'poisson'; choose one of: ") as error:
        mesh_basis_functions(curve, mesh, kernel="poisson")
    listed = str(error.value).split("choose one of: ")[1].split(", ")
    assert sorted(listed) == sorted(set(core.KERNELS) | {"pgw", "harmonic"})


@pytest.mark.parametrize(
    ("kernel", "params", "message"),
    [
        ("harmonic", {"angles": 4}, r"'harmonic' does not take parameter\(s\) angles \(it takes: none\)"),
        ("pgw", {"power": 2.0}, r"kernel 'pgw' does not take parameter\(s\) power \(it takes: angles\)"),
        ("pgw", {"angles": 0}, "angles must be at least 1"),
        ("harmonic-like", {"power": 2.0}, "does not take parameter"),
    ],
)
def test_rejects_bad_parameters(setup, kernel, params, message):
    curve, mesh = setup
    with pytest.raises(ValueError, match=message):
        mesh_basis_functions(curve, mesh, kernel=kernel, **params)


def test_rejects_bad_arguments(setup):
    curve, mesh = setup
    with pytest.raises(ValueError, match="samples_per_segment must be at least 2"):
        mesh_basis_functions(curve, mesh, samples_per_segment=1)
    with pytest.raises(ValueError, match="progress must be a callable"):
        mesh_basis_functions(curve, mesh, kernel="harmonic", progress=0.5)
    other = core.ClosedBSpline(starfish() + 0.01)
    with pytest.raises(ValueError, match="mesh was not made for this curve"):
        mesh_basis_functions(other, mesh)
    with pytest.raises(ValueError, match="mesh must be a core.Mesh"):
        mesh_basis_functions(curve, mesh.vertices)


def test_no_warnings_for_a_normal_call(setup):
    curve, mesh = setup
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mesh_basis_functions(curve, mesh, kernel="harmonic-like")


def test_cache_keys_change_with_the_numerical_code(monkeypatch):
    from core import cache

    arguments = (
        np.zeros((3, 2)),
        np.zeros((3, 2)),
        np.zeros((1, 3)),
        np.arange(3),
        np.zeros(3),
        "harmonic-like",
        100,
        {},
    )
    before = cache.cache_key(*arguments)
    monkeypatch.setattr(cache, "_code_digest", lambda: "another solver")
    assert cache.cache_key(*arguments) != before
