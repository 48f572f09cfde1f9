"""core.fold_free_deform: composite harmonic maps along the straight path of cages, each step certified
(points alone, or a mesh without its boundary); with the mesh's boundary, test_mesh_fold_free."""

from __future__ import annotations

import numpy as np
import pytest
from support.fold_free_checks import unfolded

import core
from app.studies.quality_suite import built_in_shapes, standard_suite
from core.injectivity import composite, inner_curve

#: A cage whose control point 1 pulled down to (80, 80) folds the plain harmonic map under it.
CAGE = np.array([[30, 20], [80, 30], [130, 18], [140, 60], [128, 100], [80, 92], [28, 102], [20, 60]], float)


@pytest.fixture(scope="module")
def mesh():
    return core.triangulate(core.ClosedBSpline(CAGE), max_edge=4.0)


def folds(mesh, images) -> int:
    return int(np.count_nonzero(core.folded_triangles(mesh, images)))


def test_an_affine_target_is_one_step_and_exact(mesh):
    curve = core.ClosedBSpline(CAGE)
    matrix, shift = np.array([[0.9, -0.2], [0.15, 1.05]]), np.array([18.0, -6.0])
    images, certificate = core.fold_free_deform(curve, CAGE @ matrix.T + shift, mesh.vertices)
    np.testing.assert_allclose(images, mesh.vertices @ matrix.T + shift, atol=1e-6 * curve.diameter)
    assert certificate.injective and certificate.extra["steps"] == 1
    sigma = np.linalg.svd(matrix, compute_uv=False)
    assert sigma[1] * (1 - 1e-4) <= certificate.sigma2_min <= sigma[1] * (1 + 1e-6)


def test_a_folding_drag_becomes_a_certified_bijection(mesh):
    curve = core.ClosedBSpline(CAGE)
    target = CAGE.copy()
    target[1] = [80.0, 80.0]
    plain = core.deform(core.basis_functions(curve, mesh.vertices), target)
    assert folds(mesh, plain) > 0
    _, certificate = unfolded(curve, target, mesh)
    assert certificate.injective and certificate.extra["steps"] > 1 and certificate.sigma2_min > 0


def test_progress_is_the_share_of_the_path_proven_and_an_exception_in_it_abandons(mesh):
    curve = core.ClosedBSpline(CAGE)
    target = CAGE.copy()
    target[1] = [80.0, 80.0]
    shares = []
    _, certificate = core.fold_free_deform(curve, target, mesh.vertices, progress=shares.append)
    assert len(shares) >= certificate.extra["steps"] > 1  # a call for every step tried
    assert shares == sorted(shares) and 0.0 <= shares[0] and shares[-1] == 1.0

    class Abandoned(Exception):
        pass

    def abandon(share):
        raise Abandoned

    with pytest.raises(Abandoned):
        core.fold_free_deform(curve, target, mesh.vertices, progress=abandon)


def continuous_on_mesh(curve, target, mesh):
    """`core.fold_free_deform` given the mesh's triangles but not its boundary: the continuous
    composite, its straight edges checked and repaired."""
    return core.fold_free_deform(curve, target, mesh.vertices, triangles=mesh.triangles)


def test_triangles_left_turned_over_are_counted_and_said(mesh, monkeypatch):
    """Steps taken whole (no halving for the mesh) and no repair: the drag leaves triangles turned
    over; the certificate counts them and says that the mesh is not fold-free, never "proven"."""
    monkeypatch.setattr(composite, "SMALLEST_MESH_STEP", 1.0)
    unmoved = lambda v, images, t, free: (images, np.zeros(len(v)))  # noqa: E731
    monkeypatch.setattr(composite, "unfold_triangles", unmoved)
    monkeypatch.setattr(composite, "untangle_triangles", unmoved)
    curve = core.ClosedBSpline(CAGE)
    target = CAGE.copy()
    target[1] = [120.0, 90.0]
    images, certificate = continuous_on_mesh(curve, target, mesh)
    turned = certificate.extra["turned_over"]
    assert turned == folds(mesh, images) > 0
    assert str(certificate) == (
        f"not fold-free on the mesh; {turned} mesh triangles still turned over (their straight edges "
        "are too coarse to follow the map there)"
    )


def test_boundary_points_without_parameters_stay_on_the_target_curve(mesh):
    curve = core.ClosedBSpline(CAGE)
    target = CAGE.copy()
    target[1] = [80.0, 80.0]
    images, _ = core.fold_free_deform(curve, target, mesh.vertices)
    gap = np.linalg.norm(images[mesh.boundary] - core.ClosedBSpline(target)(mesh.boundary_parameters), axis=1)
    assert gap.max() < 1e-6 * curve.diameter


def test_a_cornered_cage_is_unfolded_away_from_its_reflex_corners():
    """The F polygon (sharp corners, three of them reflex) with its arm bent down, without the mesh's
    boundary: the continuous composite, proven outside small discs at the corners (harmonic maps
    generically fold at reflex ones), radial inside."""
    points = built_in_shapes()["F polygon"]
    curve = core.ClosedBSpline(points)
    mesh = core.triangulate(curve, max_edge=0.03)
    target = points.copy()
    arm = points[:, 0] > 0.6  # the two arms' ends
    target[arm] += [0.0, -0.25]
    images, certificate = continuous_on_mesh(curve, target, mesh)
    assert not certificate.injective and certificate.away_from_corners
    # Radial discs at every sharp corner (core.injectivity.corner_discs), at most 5 % of the diameter.
    assert certificate.where.shape[1] == 2
    assert 0 < certificate.corner_radius <= inner_curve.CORNER_CAP * curve.diameter
    # With the boundary, the mesh's own map: proven a bijection on the mesh.
    _, on_mesh = unfolded(curve, target, mesh)
    assert on_mesh.injective and on_mesh.on_mesh


def test_a_path_through_a_crossing_cage_is_refused():
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    # The top pulled down below the bottom: a simple target, but halfway the cage is flat.
    target = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, -1.0], [0.0, -1.0]])
    with pytest.raises(ValueError, match="straight path from the cage to the target passes through a cage"):
        core.fold_free_deform(core.ClosedBSpline(square), target, [[0.5, 0.5]])


def test_bad_input_raises_one_clear_error():
    curve = core.ClosedBSpline(CAGE)
    crossing = CAGE.copy()
    crossing[1] = [80.0, 120.0]  # the bottom's middle pulled up through the top
    with pytest.raises(ValueError, match="^the target cannot be reached without folding: the curve crosses"):
        core.fold_free_deform(curve, crossing, [[80.0, 60.0]])
    with pytest.raises(ValueError, match="target must have shape"):
        core.fold_free_deform(curve, CAGE[:-1], [[80.0, 60.0]])
    with pytest.raises(ValueError, match="points must have shape"):
        core.fold_free_deform(curve, CAGE, [1.0, 2.0, 3.0])


@pytest.mark.parametrize(("name", "label"), [("C-shape", "drag 12"), ("character", "drag 5")])
def test_the_quality_suites_hardest_drags_leave_no_triangle_turned_over(name, label):
    """Two of the quality suite's drags (app.studies.quality_suite) where the continuous composite's
    straight edges turned triangles over: boundary triangles whose chord cuts off the third vertex
    (C-shape), and rows of triangles squeezed against a bulge of the target (character).  The mesh's
    own composite keeps them all positive: proven on the mesh, nothing leaves the target."""
    domain = next(domain for domain in standard_suite() if domain.name == name)
    target = next(deformation.target for deformation in domain.deformations if deformation.label == label)
    curve = core.ClosedBSpline(domain.control_points)
    mesh = core.triangulate(curve)
    _, certificate = unfolded(curve, target, mesh)
    assert certificate.injective and certificate.on_mesh
    assert str(certificate).startswith("fold-free on the mesh, proven (")


def test_a_step_that_no_size_proves_is_refused_as_a_limit_of_the_proof(monkeypatch):
    """(A cage whose derivatives the solve got wrong took minutes to get there, ten certificates
    of ~60,000 samples: a certificate that never proves stands in for it.)"""
    unproven = core.InjectivityCertificate(False, 0.0, np.inf, np.array([[1.5, 2.5]]), "why not")
    monkeypatch.setattr(composite, "certify_injective", lambda current, cage: unproven)
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    with pytest.raises(
        ValueError, match=r"not even one of 0.000976562 .* limit of the proof .* near \(1.5, 2.5\): why not$"
    ):
        core.fold_free_deform(core.ClosedBSpline(square), square * 1.1, [[0.5, 0.5]])


def test_the_starfish_spike_that_stalled_the_composite_is_unfolded():
    """The quality suite's starfish drag 3 (its simple straight path pinches an arm to a 3-px spike)
    stalled at 47/64 of the way: no step from that cage was proven, down to 1/1024 of the way, as
    the solve's density beside the spike's tip was wrong (test_poisson).  From that cage on, the
    composite reaches the target: proven, nothing turned over, the boundary on the target."""
    domain = standard_suite(demos=("starfish",))[0]
    target = next(d.target for d in domain.deformations if d.label == "drag 3")
    curve = core.ClosedBSpline(domain.control_points + 47 / 64 * (target - domain.control_points))
    mesh = core.triangulate(curve, max_edge=8.0)
    _, certificate = unfolded(curve, target, mesh)
    assert certificate.injective and certificate.sigma2_min > 0
