"""``warp --report``: the deformation's worst Jacobians (distortion.worst_distortion) on stdout."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from support.commands import AFFINE, CAGE, files, private_cache, run_main, warp_argv  # noqa: F401 (fixtures)

import core
from core.meshes.distortion import signed_singular_values, vertex_jacobians, worst_distortion

LINE = re.compile(r"^(min det J|max sigma1/sigma2): (\S+) at \((\S+), (\S+)\) px$")


def parse(out: str) -> dict:
    values = {}
    lines = out.strip().split("\n")
    assert len(lines) == 4, out
    assert lines[3].startswith("certificate: "), lines[3]
    values["certificate"] = lines[3].removeprefix("certificate: ")
    for line in lines[:2]:
        match = LINE.match(line)
        assert match, line
        values[match[1]] = (float(match[2]), np.array([float(match[3]), float(match[4])]))
    folded = re.match(r"^det J <= 0: (\d+) of (\d+) (.*)$", lines[2])
    assert folded, lines[2]
    values["folded"] = (int(folded[1]), int(folded[2]), folded[3])
    return values


@pytest.mark.parametrize(
    ("kernel", "points"),
    [
        ("harmonic", "triangles (per-triangle"),
        ("inverse-cube-mean", "interior vertices (exact"),
        ("inverse-cube-mean:arc-length", "triangles (per-triangle"),  # no pointwise gradients there
    ],
)
def test_an_affine_move_reports_its_own_jacobian_everywhere(files, capfd, kernel, points):  # noqa: F811
    kernel, _, parameterization = kernel.partition(":")
    extra = ["--parameterization", parameterization] if parameterization else []
    code, out, err = run_main([*warp_argv(files), "--kernel", kernel, *extra, "--report"], capfd)
    assert code == 0, err
    report = parse(out)
    # Linear precision: J = A at every point (exact per triangle for the P1 harmonic basis, to the
    # Newton tolerance over the distance for the point kernels).
    sigma = signed_singular_values(AFFINE[None, :, :2])[0]
    assert report["min det J"][0] == pytest.approx(np.linalg.det(AFFINE[:, :2]), rel=1e-6)
    assert report["max sigma1/sigma2"][0] == pytest.approx(sigma[0] / sigma[1], rel=1e-6)
    folded, count, label = report["folded"]
    assert folded == 0 and count > 50 and label.startswith(points)


def test_a_folding_move_is_found_where_it_folds(files, capfd):  # noqa: F811
    # Control point 1 (80, 30) pulled down across the cage to (80, 115): the top folds over.
    target = np.array(CAGE, dtype=float)
    target[1] = [80.0, 115.0]
    (files / "fold.json").write_text(json.dumps({"control_points": target.tolist()}))
    code, out, err = run_main(
        [*warp_argv(files, **{"--target": files / "fold.json"}), "--kernel", "inverse-cube-mean", "--report"],
        capfd,
    )
    assert code == 0, err
    report = parse(out)
    determinant, where = report["min det J"]
    assert determinant < 0 and report["folded"][0] > 0
    assert "fold.json may need a gentler move" in err  # the target curve itself is simple
    # The worst fold is near the moved point's span, in the top half of the source cage.
    assert 30 <= where[0] <= 130 and where[1] <= 60


def test_a_target_that_crosses_itself_is_named_in_the_fold_warning(files, capfd):  # noqa: F811
    target = np.array(CAGE, dtype=float)
    target[1] = [80.0, 160.0]  # through the bottom side: the target curve crosses itself
    (files / "crossed.json").write_text(json.dumps({"control_points": target.tolist()}))
    code, _, err = run_main([*warp_argv(files, **{"--target": files / "crossed.json"})], capfd)
    assert code == 0, err  # a legitimate request: the picture is written, folds and all
    assert "crossed.json: the curve crosses or touches itself near control points 1 and 5" in err


def test_worst_distortion_matches_the_jacobians_it_is_given():
    curve = core.ClosedBSpline(np.array(CAGE, dtype=float))
    rng = np.random.default_rng(31)
    x = np.array([[60.0, 50.0], [90.0, 70.0], [110.0, 40.0], [45.0, 80.0]])
    target = np.array(CAGE, dtype=float) + rng.normal(0, 6, (len(CAGE), 2))
    jacobians = vertex_jacobians(core.basis_gradients(curve, x), target)
    # The Jacobian is the derivative of the deformation x -> G(x) P'.
    step = 1e-4
    for d in range(2):
        offset = np.zeros(2)
        offset[d] = step
        difference = (
            core.basis_functions(curve, x + offset) - core.basis_functions(curve, x - offset)
        ) @ target
        np.testing.assert_allclose(jacobians[:, :, d], difference / (2 * step), rtol=0, atol=1e-7)
    worst = worst_distortion(np.vstack([jacobians, np.full((1, 2, 2), np.nan)]), np.vstack([x, [[0, 0]]]))
    determinants = np.linalg.det(jacobians)
    assert worst.count == 4
    assert worst.smallest_determinant == pytest.approx(determinants.min(), rel=1e-12)
    np.testing.assert_array_equal(worst.smallest_at, x[np.argmin(determinants)])
    assert worst.folded == int((determinants <= 0).sum())


def test_report_refuses_wrong_shapes():
    with pytest.raises(ValueError, match=r"gradients must have shape \(M, 3, 2\)"):
        vertex_jacobians(np.zeros((4, 2, 2)), np.zeros((3, 2)))
    with pytest.raises(ValueError, match="must match"):
        worst_distortion(np.zeros((4, 2, 2)), np.zeros((3, 2)))
    with pytest.raises(ValueError, match="no finite Jacobian"):
        worst_distortion(np.full((1, 2, 2), np.nan), np.zeros((1, 2)))


def test_report_prints_the_certificate_of_a_harmonic_map(files, capfd):  # noqa: F811
    code, out, err = run_main([*warp_argv(files), "--report"], capfd)
    assert code == 0, err
    assert parse(out)["certificate"].startswith("fold-free, proven (σ₂ ≥ ")
    code, out, err = run_main([*warp_argv(files), "--kernel", "inverse-cube-mean", "--report"], capfd)
    assert code == 0, err
    assert parse(out)["certificate"] == "n/a (not a harmonic map)"


def test_fold_free_unfolds_a_folding_move_and_proves_it(files, capfd):  # noqa: F811
    # Control point 1 (80, 30) pulled down to (80, 80): the plain harmonic map folds under it.
    target = np.array(CAGE, dtype=float)
    target[1] = [80.0, 80.0]
    (files / "fold.json").write_text(json.dumps({"control_points": target.tolist()}))
    argv = [*warp_argv(files, **{"--target": files / "fold.json"}), "--report"]
    code, out, err = run_main(argv, capfd)
    assert code == 0, err
    plain = parse(out)
    assert plain["folded"][0] > 0 and plain["certificate"].startswith("not proven fold-free")
    code, out, err = run_main([*argv, "--fold-free"], capfd)
    assert code == 0, err
    fold_free = parse(out)
    # One truth: the count is that of the map whose pixels are written, and "proven" never stands
    # beside "folds over".
    assert fold_free["folded"][0] == 0 and fold_free["folded"][2].startswith("triangles")
    assert fold_free["certificate"].startswith("fold-free on the mesh, proven (the mesh's ")
    assert "folds over" not in err


def test_fold_free_keeps_a_plain_map_that_does_not_fold_and_its_continuous_certificate(files, capfd):  # noqa: F811
    code, out, err = run_main([*warp_argv(files), "--report", "--fold-free"], capfd)
    assert code == 0, err
    report = parse(out)
    assert report["folded"][0] == 0 and report["certificate"].startswith("fold-free, proven (σ₂ ≥ ")


def test_fold_free_needs_the_harmonic_kernel(files, capfd):  # noqa: F811
    code, out, err = run_main([*warp_argv(files), "--fold-free", "--kernel", "mean-value"], capfd)
    assert code == 2 and err.count("\n") == 1 and "use the poisson kernel" in err
