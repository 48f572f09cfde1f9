"""app.studies.quality and app.studies.quality_suite: the suite is reproducible, the measures are
right on maps with known answers, and ``python -m app quality`` runs on a tiny suite."""

from __future__ import annotations

import numpy as np
import pytest

from app.__main__ import main
from app.io.files import InputError, read_image
from app.studies.quality import KernelChoice, format_table, parse_kernel, run_study
from app.studies.quality_suite import Deformation, Domain, handles, polygon, standard_suite
from core.curves import examples

AFFINE = np.array([[1.6, 0.5], [-0.2, 0.8]])


@pytest.fixture(autouse=True)
def private_cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("TRANSFINITE_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))


def known_suite() -> list[Domain]:
    """The blob left alone, moved affinely, and with the notch's bottom point pushed deep into it."""
    points = examples.blob()
    dragged = points.copy()
    dragged[8] += [0.0, -0.4]
    return [
        Domain(
            "blob",
            points,
            [
                Deformation("identity", points),
                Deformation("affine", points @ AFFINE.T + [3.0, 1.0]),
                Deformation("drag", dragged),
            ],
        )
    ]


@pytest.fixture(scope="module")
def study():
    choices = [KernelChoice("harmonic", "harmonic"), KernelChoice("pseudo-harmonic", "pseudo-harmonic")]
    return run_study(known_suite(), choices)


def test_the_suite_is_the_same_for_the_same_seed():
    first, second, other = standard_suite(3), standard_suite(3), standard_suite(4)
    assert [d.name for d in first] == [d.name for d in second]
    for a, b in zip(first, second, strict=True):
        for x, y in zip(a.deformations, b.deformations, strict=True):
            assert x.label == y.label
            np.testing.assert_array_equal(x.target, y.target)
    assert any(
        not np.array_equal(x.target, y.target)
        for a, b in zip(first, other, strict=True)
        for x, y in zip(a.deformations, b.deformations, strict=True)
    )


def test_each_domain_gets_two_drags_two_moves_and_two_bends_of_the_right_size():
    for domain in standard_suite():
        points = domain.control_points
        diameter = np.max(np.linalg.norm(points[:, None] - points[None], axis=2))
        kinds = [deformation.label.split()[0] for deformation in domain.deformations]
        assert kinds == ["drag", "drag", "move", "move", "bend", "bend"]
        for deformation in domain.deformations[:4]:
            moved = np.linalg.norm(deformation.target - points, axis=1)
            expected = (0.25 if deformation.label.startswith("drag") else 0.15) * diameter
            np.testing.assert_allclose(moved[moved > 0], expected, rtol=1e-12)
        for deformation in domain.deformations[4:]:
            # A bend is rigid on each half: distances within the moved half are kept.
            moved = np.any(deformation.target != points, axis=1)
            a, b = points[moved], deformation.target[moved]
            np.testing.assert_allclose(
                np.linalg.norm(a[:, None] - a[None], axis=2), np.linalg.norm(b[:, None] - b[None], axis=2),
                rtol=0, atol=1e-12 * diameter,
            )  # fmt: skip


def test_doubled_control_points_move_as_one_handle():
    square = polygon([[0, 0], [1, 0], [1, 1], [0, 1]])
    assert [group.tolist() for group in handles(square)] == [[0, 1], [2, 3], [4, 5], [6, 7]]
    wrapped = np.roll(square, 1, axis=0)  # the first handle now wraps around the end
    assert [group.tolist() for group in handles(wrapped)] == [[1, 2], [3, 4], [5, 6], [7, 0]]


def test_identity_and_affine_maps_have_the_known_measures(study):
    affine_ratio = np.divide(*np.linalg.svd(AFFINE, compute_uv=False))
    for result in study.kernels:
        assert study.deformations == [("blob", "identity"), ("blob", "affine"), ("blob", "drag")]
        # Identity and affine: every barycentric map reproduces them (to the Newton tolerance).
        assert result.folded[:2] == [0.0, 0.0]
        assert result.outside[:2] == [0.0, 0.0]
        assert result.distortion_mean[0] == pytest.approx(1.0, abs=1e-8)
        assert result.distortion_99[0] == pytest.approx(1.0, abs=1e-8)
        assert result.distortion_mean[1] == pytest.approx(affine_ratio, rel=1e-8)
        assert result.distortion_99[1] == pytest.approx(affine_ratio, rel=1e-8)
        assert result.map_rms[:2] == pytest.approx([0.0, 0.0], abs=1e-9)
    harmonic, other = study.kernels
    assert harmonic.map_rms == [0.0, 0.0, 0.0] and harmonic.height_rms == [0.0]
    assert other.map_rms[2] > 1e-3 and other.height_rms[0] > 1e-3


def test_the_dragged_target_folds_and_spills(study):
    # The interior near the pushed point cannot follow the boundary's sharp turn: every map folds.
    for result in study.kernels:
        assert result.folded[2] > 0
        assert result.outside[2] > 0
        assert result.distortion_99[2] == 10.0  # folded triangles count as the cap
        summary = result.summary()
        assert summary["with folds"] == 1 and summary["deformations"] == 3


def test_the_numbers_are_the_same_twice(study):
    again = run_study(known_suite(), [result.choice for result in study.kernels])
    for first, second in zip(study.kernels, again.kernels, strict=True):
        for name in ("folded", "outside", "distortion_mean", "distortion_99", "map_rms", "height_rms"):
            assert getattr(first, name) == getattr(second, name), name


def test_self_crossing_targets_are_set_aside():
    points = examples.blob()
    crossing = points.copy()
    crossing[0], crossing[6] = points[6], points[0]
    suite = [Domain("blob", points, [Deformation("swap", crossing), Deformation("identity", points)])]
    study = run_study(suite, [KernelChoice("harmonic", "harmonic")])
    assert study.self_crossing == [("blob", "swap")]
    assert study.deformations == [("blob", "identity")]
    assert study.kernels[0].folded == [0.0]


def test_parse_kernel():
    assert parse_kernel("pgw") == KernelChoice("pgw", "pgw", {})
    choice = parse_kernel("power:power=2.5,shift=mean")
    assert choice == KernelChoice("power:power=2.5,shift=mean", "power", {"power": 2.5, "shift": "mean"})
    with pytest.raises(InputError, match="unknown kernel 'cubic'"):
        parse_kernel("cubic:power=3")
    with pytest.raises(InputError, match="expected NAME:param=value"):
        parse_kernel("power:2.5")


def test_a_kernel_that_rejects_the_domain_is_skipped_with_the_reason():
    study = run_study(known_suite(), [KernelChoice("harmonic", "harmonic"), KernelChoice("w", "wachspress")])
    assert "convex domains only" in study.kernels[1].skipped
    assert "w " not in format_table(study)


def test_the_command_prints_the_table_and_draws_the_figure(tmp_path, capfd):
    figure = tmp_path / "quality.png"
    code = main(
        ["quality", "--domain", "hook", "--kernel", "power:power=2,shift=mean", "--output", str(figure)]
    )
    out, err = capfd.readouterr()
    assert code == 0, err
    assert out.startswith("1 domains (hook;")
    for label in ("harmonic ", "harmonic-like", "mean-value", "pgw", "power:power=2,shift=mean"):
        assert label in out
    assert f"wrote {figure}" in err
    image = read_image(figure)
    assert image.shape[2] == 4 and image.shape[0] > 100


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--domain", "moon"], "--domain: unknown moon"),
        (["--kernel", "power:shift"], "expected NAME:param=value"),
        (["--kernel", "power:power=-1"], "power must be"),
        (["--kernel", "mean-value:power=3"], "does not take parameter(s) power"),
        (["--output", "figure.txt"], ".png"),
    ],
)
def test_bad_options_are_one_line_and_exit_2(argv, message, capfd, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code = main(["quality", *argv])
    out, err = capfd.readouterr()
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and message in err


def test_help_describes_the_measures_with_examples():
    from app.commands.cli import build_parser

    parser = build_parser("transfinite-warp")
    command = next(a for a in parser._actions if a.dest == "command").choices["quality"]
    text = command.format_help()
    assert text.startswith("usage: transfinite-warp quality ")
    assert "examples:\n  transfinite-warp quality" in text
    for word in ("folded area", "outside the target", "s1/s2", "harmonic", "Self-crossing"):
        assert word in text


def test_the_fold_free_row_unfolds_the_drag_and_says_what_is_proven():
    choices = [
        KernelChoice("poisson", "poisson"),
        KernelChoice("poisson, fold-free", "poisson", fold_free=True),
    ]
    study = run_study(known_suite(), choices)
    _, plain, fold_free = study.kernels
    assert plain.proven == [True, True, False] and plain.folded[2] > 0
    assert fold_free.proven == [True, True, True]
    # The composite is proven a bijection, and the few triangles of this coarse mesh (1.5k vertices)
    # that its straight edges turn over where it compresses hardest are unfolded.
    assert fold_free.folded == [0.0, 0.0, 0.0]
    assert fold_free.outside == [0.0, 0.0, 0.0]
    assert max(fold_free.boundary_gap) < 1e-3
    assert fold_free.summary()["proven"] == 3
    table = format_table(study)
    assert " 3/3 " in table.splitlines()[-1] and "n/a" in table.splitlines()[1]
