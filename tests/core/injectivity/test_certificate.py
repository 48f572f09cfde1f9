"""core.certify_injective: never wrong against a dense check, and proves most fold-free maps.

The dense check evaluates the exact Jacobian of the harmonic map (`core.injectivity.harmonic_parts`)
at 500 points per deformation, 10⁵ over the 200 deformations: 400 uniformly inside and 100 at
10⁻⁵ to 10⁻² diameters from the boundary (half of those next to knots and corners), where folds
begin.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from support.shapes import interior_points

import core
from app.studies.quality_suite import handles, polygon
from core.boundary_integrals import poisson
from core.curves import examples
from core.injectivity.certificate import InjectivityCertificate
from core.injectivity.harmonic_parts import complex_derivatives

CAGES = {
    "ellipse": examples.ellipse(8),
    "blob": examples.blob(),
    "square polygon": polygon([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
    "L polygon": polygon([[0.0, 0.0], [1.0, 0.0], [1.0, 0.4], [0.4, 0.4], [0.4, 1.0], [0.0, 1.0]]),
}
#: A 200-point cage on a five-lobed circle of radius ~150 px, and a 20-point one.
LOBED = examples.lobed_circle(200) * 150.0 + 300.0
SMALL = examples.lobed_circle(20) * 150.0 + 300.0
PER_CAGE = 50
POINTS, NEAR = 400, 100


def random_targets(points: np.ndarray, count: int, seed: int) -> list[np.ndarray]:
    """`count` targets of a cage (n, 2): every handle (doubled points together) moved by a random vector
    of up to 0.02 .. 0.3 of the diameter, the amplitude drawn per target."""
    rng = np.random.default_rng(seed)
    diameter = float(np.ptp(points, axis=0).max())
    groups = handles(points)
    targets = []
    for _ in range(count):
        amplitude = rng.uniform(0.02, 0.3) * diameter
        target = points.copy()
        for group in groups:
            target[group] += amplitude * rng.uniform(-1.0, 1.0, 2)
        targets.append(target)
    return targets


def near_boundary(curve: core.ClosedBSpline, count: int, seed: int) -> np.ndarray:
    """`count` points 1e-5 .. 1e-2 diameters inside the curve along its normal, half next to knots."""
    rng = np.random.default_rng(seed)
    half = count // 2
    t = np.concatenate(
        [rng.uniform(0, curve.n, count - half), rng.integers(0, curve.n, half) + rng.normal(0, 0.05, half)]
    )
    point, tangent, _ = curve.evaluate(np.mod(t, curve.n))
    speed = np.linalg.norm(tangent, axis=1)
    keep = speed > 1e-6 * curve.diameter
    normal = np.stack([-tangent[keep, 1], tangent[keep, 0]], axis=1) / speed[keep, None]
    normal *= 1.0 if curve.area > 0 else -1.0
    depth = curve.diameter * 10.0 ** rng.uniform(-5, -2, keep.sum())
    x = point[keep] + depth[:, None] * normal
    return x[curve.contains(x)]


def dense_check(curve, target, points):
    """σ₂, k and det J (each (M,)) of the harmonic map at points (M, 2)."""
    h, g, _ = complex_derivatives(curve, target, points)
    return np.abs(h) - np.abs(g), np.abs(g) / np.abs(h), np.abs(h) ** 2 - np.abs(g) ** 2


@pytest.fixture(scope="module")
def study():
    """Per deformation: (cage name, target valid, certificate, σ₂, k, det J, points)."""
    core.boundary_integrals.poisson.load_compiled()
    rows = []
    for c, (name, points) in enumerate(CAGES.items()):
        curve = core.ClosedBSpline(points)
        dense = np.concatenate([interior_points(curve, POINTS, seed=c), near_boundary(curve, NEAR, seed=c)])
        for target in random_targets(points, PER_CAGE, seed=100 + c):
            certificate = core.certify_injective(curve, target)
            try:
                core.ClosedBSpline(target)
            except ValueError:
                rows.append((name, False, certificate, None, None, None, dense))
                continue
            rows.append((name, True, certificate, *dense_check(curve, target, dense), dense))
    return rows


def test_at_least_200_deformations_with_and_without_corners(study):
    assert len(study) >= 200
    assert sum(valid for _, valid, *_ in study) >= 150


def test_the_certificate_is_never_wrong(study):
    checked = 0
    for name, valid, certificate, sigma2, k, det, dense in study:
        assert isinstance(certificate, InjectivityCertificate)
        if not (certificate.injective or certificate.away_from_corners):
            assert certificate.sigma2_min == 0.0 and certificate.k_max == math.inf
            continue
        assert valid, name
        outside_discs = np.ones(len(dense), dtype=bool)
        for corner in certificate.where:
            outside_discs &= np.linalg.norm(dense - corner, axis=1) > certificate.corner_radius
        assert det[outside_discs].min() > 0, name
        scale = float(np.ptp(dense, axis=0).max())
        assert sigma2[outside_discs].min() >= certificate.sigma2_min - 1e-6 * scale, name
        assert k[outside_discs].max() <= certificate.k_max + 1e-9, name
        checked += 1
    assert checked >= 60


def test_reflex_corners_are_never_proven_but_the_rest_is(study):
    """The harmonic map folds, generically, in a tiny disc at a reflex corner (the module's notes)."""
    reflex = [row for row in study if row[0] == "L polygon"]
    assert not any(certificate.injective for _, _, certificate, *_ in reflex)
    assert any(certificate.away_from_corners for _, _, certificate, *_ in reflex)


def test_proves_most_maps_that_are_fold_free_with_margin(study):
    """Of the maps (cages without reflex corners) whose dense min det J is at least 5 % of its mean,
    at least 80 % are proven."""
    margin = [
        row for row in study if row[1] and row[0] != "L polygon" and row[5].min() >= 0.05 * row[5].mean()
    ]
    proven = sum(row[2].injective for row in margin)
    assert len(margin) >= 40
    assert proven >= 0.8 * len(margin), f"{proven} of {len(margin)}"


def test_a_folding_map_is_refused_and_marked():
    curve = core.ClosedBSpline(examples.blob())
    target = curve.control_points.copy()
    target[3] += 0.8 * curve.diameter * (curve.control_points.mean(axis=0) - target[3])
    certificate = core.certify_injective(curve, target)
    assert not certificate.injective and certificate.sigma2_min == 0.0
    assert certificate.where.shape[1] == 2 and certificate.where.shape[0] >= 1
    assert str(certificate).startswith("not proven fold-free")


def test_the_identity_and_a_similarity_are_proven_with_their_singular_values():
    curve = core.ClosedBSpline(examples.blob())
    identity = core.certify_injective(curve, curve.control_points)
    assert identity.injective and identity.k_max < 1e-3 and 0.99 < identity.sigma2_min <= 1.0 + 1e-6
    rotation = np.array([[0.6, -0.8], [0.8, 0.6]])
    similar = core.certify_injective(curve, 2.0 * curve.control_points @ rotation.T + 5.0)
    assert similar.injective and similar.k_max < 1e-3 and 1.98 < similar.sigma2_min <= 2.0 + 1e-5


def test_a_clockwise_cage_is_certified_like_its_mirror_image():
    points = examples.blob()
    target = points + 0.05 * np.sin(np.arange(len(points)))[:, None]
    mirror = np.array([1.0, -1.0])
    first = core.certify_injective(core.ClosedBSpline(points), target)
    second = core.certify_injective(core.ClosedBSpline(points * mirror), target * mirror)
    assert first.injective == second.injective
    assert second.sigma2_min == pytest.approx(first.sigma2_min, rel=1e-6)


def test_a_target_that_turns_the_other_way_is_refused():
    points = examples.ellipse(8)
    certificate = core.certify_injective(core.ClosedBSpline(points), points[::-1].copy())
    assert not certificate.injective and "other way" in certificate.reason


def test_a_corner_that_is_not_a_corner_of_the_target_is_refused():
    points = polygon([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    target = points.copy()
    target[1] += [0.01, 0.0]
    certificate = core.certify_injective(core.ClosedBSpline(points), target)
    assert not certificate.injective and "sharp corner" in certificate.reason


def test_bad_input_raises_one_clear_error():
    curve = core.ClosedBSpline(examples.blob())
    with pytest.raises(ValueError, match="supports the kernel"):
        core.certify_injective(curve, curve.control_points, kernel="mean-value")
    with pytest.raises(ValueError, match="target must have shape"):
        core.certify_injective(curve, curve.control_points[:-1])
    with pytest.raises(ValueError, match="curve must be a core.ClosedBSpline"):
        core.certify_injective(curve.control_points, curve.control_points)


def test_a_new_200_point_cages_certificate_is_the_same_proof_within_its_time_limit():
    """Issue 46: a 200-point cage's certificate from cold (its densities not solved; the compiled code
    loaded) solves for the map's combined right-hand sides alone (5 columns, not 201:
    `poisson.combined_levels`), ≤ 1 s on a quiet machine (the bench's row measures it).  The limits
    here are for a loaded shared machine: 3 s of the process's CPU time (both threads; load does not
    stretch it as it does the wall clock: 0.8-1.3 s measured at a load of 9-17 on 2 cores, where the
    wall clock read 2.3-6.7 s, and the solve of all 201 columns 14-19 s, CPU 3.1-3.2 s), 10 s of wall.
    It proves what the cage's densities prove, to the evaluation's rounding; a second target of
    the cage solves them all."""
    poisson.load_compiled()
    core.certify_injective(core.ClosedBSpline(SMALL), SMALL * 1.1)  # the compiled code read in
    points = LOBED * 1.001  # a cage no other test solves
    curve, target = core.ClosedBSpline(points), points.copy()
    target[10] += [0.0, 5.0]  # a moderate drag (45 px folds the map: refused at once)
    started, cpu = time.perf_counter(), time.process_time()
    cold = core.certify_injective(curve, target)
    assert time.process_time() - cpu < 3.0
    assert time.perf_counter() - started < 10.0
    key = poisson.centred(curve, points)[0].control_points.tobytes()
    assert key not in poisson._held  # the cage's densities were not solved
    core.certify_injective(curve, points * 1.1)  # a second target: all the densities
    assert key in poisson._held
    solved = core.certify_injective(curve, target)
    assert cold.injective and solved.injective and cold.samples == solved.samples
    assert abs(cold.sigma2_min - solved.sigma2_min) <= 1e-9 * solved.sigma2_min
    assert abs(cold.k_max - solved.k_max) <= 1e-9 * solved.k_max
