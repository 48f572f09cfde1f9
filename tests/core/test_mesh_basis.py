"""Tests of core.mesh_basis and core.storage.cache: basis functions at mesh vertices, cached on disk."""

import hashlib
import os
import re
import shutil
import warnings

import numpy as np
import pytest
from support.shapes import wavy_star as starfish

import core
from core import mesh_basis
from core.mesh_basis import MESH_ONLY_KERNELS, mesh_basis_functions
from core.meshes.harmonic import harmonic_basis
from core.meshes.pgw import pgw_basis
from core.meshes.triangulation import triangulate
from core.storage import cache as disk_cache


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


def test_the_default_kernel_writes_its_interior_rows_in_place_and_gives_the_same_values(setup):
    # The interior vertices of a triangulation are one range of rows: poisson_basis writes them
    # there (no copy, no fresh array); a mesh whose interior is not one range takes the copy.
    from core.basis import basis_functions
    from core.meshes.mesh import Mesh

    curve, mesh = setup
    inside = mesh.vertices[mesh.interior]
    assert np.all(np.diff(mesh.interior) == 1)
    values = mesh_basis_functions(curve, mesh, cache=False)
    np.testing.assert_array_equal(values[mesh.interior], basis_functions(curve, inside))
    order = np.concatenate([mesh.interior[::2], mesh.boundary, mesh.interior[1::2]])  # interleaved
    position = np.empty_like(order)
    position[order] = np.arange(order.size)
    shuffled = Mesh(
        mesh.vertices[order], position[mesh.triangles], position[mesh.boundary], mesh.boundary_parameters
    )
    assert not np.all(np.diff(shuffled.interior) == 1)
    # Other points share the boxes of the evaluation, so the sums' order may differ.
    shuffled_values = mesh_basis_functions(curve, shuffled, cache=False)
    np.testing.assert_allclose(shuffled_values, values[order], rtol=0, atol=1e-14)


def test_mesh_only_kernels():
    assert MESH_ONLY_KERNELS == ("pgw", "harmonic")


# ---------------------------------------------------------------- cache


def test_second_call_reads_the_cache(setup, cache_directory, monkeypatch):
    curve, mesh = setup
    first = mesh_basis_functions(curve, mesh, kernel="harmonic")
    files = list(cache_directory.glob("*.npz"))
    assert len(files) == 1

    def fail(*args):
        raise AssertionError("recomputed instead of reading the cache")

    monkeypatch.setattr(mesh_basis, "_compute", fail)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
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
    assert len(list(cache_directory.glob("*.npz"))) == 4
    mesh_basis_functions(curve, mesh, kernel="pgw", angles=np.int64(16))  # same key as angles=16
    assert len(list(cache_directory.glob("*.npz"))) == 4


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
        "parameterization": "arc-length",
    }
    for name, value in changes.items():
        assert disk_cache.cache_key(**(arguments | {name: value})) != key, name


# ---------------------------------------------------------------- a cache that cannot lie


def rewrite(path, basis, errors, checksum):
    with open(path, "wb") as stream:
        np.savez(stream, basis=basis, errors=errors, checksum=np.array(checksum))


def stored(path):
    with np.load(path) as file:
        return file["basis"], file["errors"], str(file["checksum"])


def flip_bit(values, seed):
    rng = np.random.default_rng(seed)
    damaged = values.copy()
    bits = damaged.reshape(-1).view(np.uint64)
    index = int(rng.integers(bits.size))
    bits[index] ^= np.uint64(1) << np.uint64(rng.integers(52))  # a mantissa bit: still finite
    return damaged


def swap_columns(values):
    return values[:, [1, 0, *range(2, values.shape[1])]]


def random_values(values, seed):
    return np.random.default_rng(seed).uniform(-1.0, 1.0, values.shape)


def truncate(path):
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


def random_bytes(path):
    path.write_bytes(np.random.default_rng(3).bytes(path.stat().st_size))


def flip_file_bit(path):
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x10  # inside the array's bytes: the zip CRC no longer matches
    path.write_bytes(bytes(data))


FILE_DAMAGE = {
    "truncated": truncate,
    "random bytes": random_bytes,
    "a bit flipped in the file": flip_file_bit,
}
ARRAY_DAMAGE = {
    "two columns swapped": swap_columns,
    "one bit flipped": lambda values: flip_bit(values, seed=4),
    "random finite values": lambda values: random_values(values, seed=5),
}


def expect_recomputed(curve, mesh, kernel, path, expected, problem):
    """The damaged entry is found, recomputed to the uncached result, replaced and reported."""
    with pytest.warns(core.CacheWarning) as caught:
        values = mesh_basis_functions(curve, mesh, kernel=kernel)
    (warning,) = caught
    message = str(warning.message)
    assert "\n" not in message
    assert re.search(
        rf"{re.escape(str(path))} could not be used \({problem}.*\); recomputed them and replaced", message
    )
    np.testing.assert_array_equal(values, expected)
    np.testing.assert_array_equal(stored(path)[0], expected)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the replaced entry is intact: read without a word
        np.testing.assert_array_equal(mesh_basis_functions(curve, mesh, kernel=kernel), expected)


@pytest.mark.parametrize("damage", FILE_DAMAGE)
def test_a_damaged_cache_file_is_recomputed_replaced_and_reported(setup, cache_directory, damage):
    curve, mesh = setup
    expected = mesh_basis_functions(curve, mesh, kernel="harmonic-like", cache=False)
    mesh_basis_functions(curve, mesh, kernel="harmonic-like")
    (path,) = cache_directory.glob("*.npz")
    FILE_DAMAGE[damage](path)
    expect_recomputed(curve, mesh, "harmonic-like", path, expected, "unreadable")


@pytest.mark.parametrize("damage", ARRAY_DAMAGE)
def test_a_changed_array_fails_the_checksum(setup, cache_directory, damage):
    curve, mesh = setup
    expected = mesh_basis_functions(curve, mesh, kernel="harmonic-like", cache=False)
    mesh_basis_functions(curve, mesh, kernel="harmonic-like")
    (path,) = cache_directory.glob("*.npz")
    basis, errors, checksum = stored(path)
    np.testing.assert_array_equal(basis, expected)
    rewrite(path, ARRAY_DAMAGE[damage](basis), errors, checksum)
    expect_recomputed(curve, mesh, "harmonic-like", path, expected, "checksum mismatch")


@pytest.mark.parametrize(
    ("kernel", "damage", "problem"),
    [
        ("harmonic-like", "two columns swapped", "its boundary rows are not the B-spline basis"),
        ("harmonic-like", "random finite values", "its boundary rows"),
        ("pseudo-harmonic", "interior columns swapped", "G @ P misses the vertices"),
        ("harmonic", "interior rows rescaled", "rows sum to 1 only within"),
        ("pgw", "interior columns swapped", "G @ P misses the vertices"),
    ],
)
def test_a_consistently_checksummed_wrong_array_fails_the_invariants(
    setup, cache_directory, kernel, damage, problem
):
    # A second line of defence: even with a checksum that matches, the invariants that
    # hold to rounding (or to the Newton tolerance) catch a wrong array.
    curve, mesh = setup
    params = {"angles": 64} if kernel == "pgw" else {}
    expected = mesh_basis_functions(curve, mesh, kernel=kernel, cache=False, **params)
    mesh_basis_functions(curve, mesh, kernel=kernel, **params)
    (path,) = cache_directory.glob("*.npz")
    basis, errors, _ = stored(path)
    interior = mesh.interior
    wrong = basis.copy()
    if damage == "interior columns swapped":
        wrong[interior] = swap_columns(basis)[interior]
    elif damage == "interior rows rescaled":
        wrong[interior] *= 1.0 + 1e-9
    else:
        wrong = ARRAY_DAMAGE[damage](basis)
    key = path.stem
    rewrite(path, wrong, errors, disk_cache._checksum(key, wrong, errors))
    with pytest.warns(core.CacheWarning, match=re.escape(problem)):
        values = mesh_basis_functions(curve, mesh, kernel=kernel, **params)
    np.testing.assert_array_equal(values, expected)
    np.testing.assert_array_equal(stored(path)[0], expected)


def test_an_entry_of_another_shape_or_dtype_is_recomputed(setup, cache_directory):
    curve, mesh = setup
    expected = mesh_basis_functions(curve, mesh, kernel="harmonic")
    (path,) = cache_directory.glob("*.npz")
    basis, errors, checksum = stored(path)
    for wrong, problem in (
        (np.zeros((3, curve.n)), "of shape (3, "),
        (basis.astype(np.float32), "a float32 array"),
    ):
        rewrite(path, wrong, errors, checksum)
        with pytest.warns(core.CacheWarning, match=re.escape(problem)):
            np.testing.assert_array_equal(mesh_basis_functions(curve, mesh, kernel="harmonic"), expected)


def test_unconverged_points_do_not_make_an_entry_look_damaged(setup, cache_directory, monkeypatch):
    # The unshifted high powers leave points short of the Newton tolerance (Sec. 3.3); a
    # solve like that (here: weight moved between two columns, rows still summing to 1)
    # is stored with its errors, and reading it back must not report damage every time.
    curve, mesh = setup
    exact = mesh_basis_functions(curve, mesh, kernel="harmonic-like", cache=False)
    unconverged = exact.copy()
    unconverged[mesh.interior, 0] += 1e-7
    unconverged[mesh.interior, 1] -= 1e-7
    monkeypatch.setattr(mesh_basis, "_compute", lambda *arguments: unconverged.copy())
    # The rows that a read computes again come from the same solver, point by point.
    rows = {tuple(vertex): row for vertex, row in zip(mesh.vertices, unconverged, strict=True)}
    monkeypatch.setattr(
        mesh_basis, "_point_values", lambda curve, points, *rest: np.array([rows[tuple(p)] for p in points])
    )
    mesh_basis_functions(curve, mesh, kernel="harmonic-like")
    (path,) = cache_directory.glob("*.npz")
    assert stored(path)[1][1] > 1e3 * 1e-11 * curve.diameter
    monkeypatch.setattr(mesh_basis, "_compute", lambda *arguments: pytest.fail("recomputed"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        np.testing.assert_array_equal(mesh_basis_functions(curve, mesh, kernel="harmonic-like"), unconverged)


def test_writes_are_atomic_leave_no_temporary_files_and_follow_the_umask(setup, cache_directory):
    curve, mesh = setup
    previous = os.umask(0o022)
    try:
        mesh_basis_functions(curve, mesh, kernel="harmonic")
        mesh_basis_functions(curve, mesh, kernel="pgw", angles=8)
    finally:
        os.umask(previous)
    names = sorted(os.listdir(cache_directory))
    assert len(names) == 2 and all(name.endswith(".npz") and not name.startswith(".") for name in names)
    assert {(cache_directory / name).stat().st_mode & 0o777 for name in names} == {0o644}


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
    with pytest.raises(ValueError, match="unknown kernel 'gauss-seidel'; choose one of: ") as error:
        mesh_basis_functions(curve, mesh, kernel="gauss-seidel")
    listed = str(error.value).split("choose one of: ")[1].split(", ")
    assert sorted(listed) == sorted(set(core.KERNELS) | set(core.COMPLEX_KERNELS) | {"pgw", "harmonic"})


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
    from core.storage import cache

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


def test_the_code_of_every_kernel_is_in_the_cache_key(tmp_path, monkeypatch):
    # An edit of any module that computes G (here the boundary-integral kernels', which a list
    # of numerical modules had missed) changes every key; the cache's own plumbing does not.
    from core.storage import cache

    copy = tmp_path / "core"
    shutil.copytree(cache.CORE_FOLDER, copy, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(cache, "CORE_FOLDER", copy)
    digests = {}
    integrals = ("poisson.py", "cauchy_integrals.py", "compiled_integrals.py", "panels.py")
    for name in (
        *(f"boundary_integrals/{name}" for name in integrals),
        "newton/solver.py",
        "storage/atomic_write.py",
    ):
        cache._code_digest.cache_clear()
        before = cache._code_digest()
        with open(copy / name, "a") as stream:
            stream.write("\n# edited\n")
        cache._code_digest.cache_clear()
        digests[name] = before != cache._code_digest()
    cache._code_digest.cache_clear()
    assert digests == {name: name != "storage/atomic_write.py" for name in digests}


# ---------------------------------------------------------------- forged entries (issue 23)


@pytest.fixture
def state_directory(tmp_path, monkeypatch):
    """A private state directory, where the cache's key is made."""
    directory = tmp_path / "state"
    monkeypatch.setenv("TRANSFINITE_STATE_DIR", str(directory))
    return directory


def test_the_checksum_is_keyed_with_a_private_secret_outside_the_cache(
    setup, cache_directory, state_directory
):
    curve, mesh = setup
    expected = mesh_basis_functions(curve, mesh, kernel="harmonic-like")
    key_file = state_directory / "cache.key"
    assert key_file.stat().st_mode & 0o777 == 0o600
    assert not list(cache_directory.glob("*.key")) and len(key_file.read_text().strip()) == 64
    # Whoever can write the cache but not read the key cannot make a checksum that holds:
    # here one that the unkeyed SHA-256 of the previous format would have accepted.
    (path,) = cache_directory.glob("*.npz")
    basis, errors, _ = stored(path)
    wrong = swap_columns(basis)
    digest = hashlib.sha256(path.stem.encode())
    for array in (wrong, errors):
        digest.update(f"{array.dtype.str}{array.shape}\n".encode())
        digest.update(np.ascontiguousarray(array).tobytes())
    rewrite(path, wrong, errors, digest.hexdigest())
    expect_recomputed(curve, mesh, "harmonic-like", path, expected, "checksum mismatch")


@pytest.mark.parametrize("gradients", [False, True], ids=["values", "gradients"])
def test_an_entry_forged_with_the_key_that_holds_the_invariants_is_caught(
    setup, cache_directory, state_directory, gradients
):
    # Another kernel's rows sum to 1, reproduce the vertices (to the errors the forger records)
    # and have the B-spline basis on the boundary (their gradients sum to 0 and to the identity
    # against P): only computing rows again tells them apart (for the gradients, the report's
    # det J turned from 0.886 to -49.1).
    curve, mesh = setup
    result = mesh_basis_functions(curve, mesh, kernel="harmonic-like", gradients=gradients)
    forged = mesh_basis_functions(curve, mesh, kernel="mean-value", gradients=gradients, cache=False)
    if gradients:
        result, forged = result[1][mesh.interior], forged[1][mesh.interior]
    (path,) = [p for p in cache_directory.glob("*.npz") if stored(p)[0].ndim == (3 if gradients else 2)]
    errors = np.array([1e-6, 1e-3])
    rewrite(path, forged, errors, disk_cache._checksum(path.stem, forged, errors))
    with pytest.warns(core.CacheWarning, match=r"rows computed again differ from it by up to"):
        again = mesh_basis_functions(curve, mesh, kernel="harmonic-like", gradients=gradients)
    np.testing.assert_array_equal(again[1][mesh.interior] if gradients else again, result)


def test_a_key_that_others_may_read_turns_the_cache_off(setup, cache_directory, state_directory):
    curve, mesh = setup
    state_directory.mkdir()
    (state_directory / "cache.key").write_text("ab" * 32)
    os.chmod(state_directory / "cache.key", 0o644)
    with pytest.warns(
        RuntimeWarning,
        match=r"the basis-function cache is off: its key cannot be used \(.*"
        r"cache.key: others may read or write the cache key \(mode 644\); chmod 600 it\)",
    ):
        mesh_basis_functions(curve, mesh, kernel="harmonic")
    assert not list(cache_directory.glob("*.npz"))


def test_processes_making_the_key_at_once_agree_on_one(tmp_path):
    from core.storage import cache_secret

    path = tmp_path / "state" / "cache.key"
    cache_secret._create(path)
    first = path.read_text()
    cache_secret._create(path)  # a second process, which lost the race: the first key stays
    assert path.read_text() == first
    assert sorted(p.name for p in path.parent.iterdir()) == ["cache.key"]
