"""Tests of app.io.svg_cages: cages as SVG paths, exact as a chain of quadratic Béziers, fitted otherwise."""

import numpy as np
import pytest
from support.paths import ROOT

from app.io.files import InputError, read_cage, read_cage_file, write_cage
from app.io.svg_cages import FIT_TOLERANCE, svg_cage, svg_text
from core import basis_weights

STARFISH = ROOT / "assets" / "starfish.cage.json"
# A house: four sharp corners (doubled points) and a round roof.
CORNERED = np.array(
    [[10.25, 90.5], [10.25, 90.5], [10.25, 40.0], [60.125, 5.75], [110.0, 40.0], [110.0, 90.5], [110.0, 90.5]]
    + [[60.0, 90.5], [35.0, 90.5]]
)
SVG_HEAD = '<svg xmlns="http://www.w3.org/2000/svg" width="300" height="200">'


def doubled_points(control_points):
    """The points repeated twice in a row (sharp corners)."""
    following = np.roll(control_points, -1, axis=0)
    return control_points[np.all(control_points == following, axis=1)]


def curve_samples(control_points, per_span=400):
    """Points of the closed quadratic B-spline, `per_span` per span (our own evaluation)."""
    count = len(control_points)
    index, weights = basis_weights(np.linspace(0, count, per_span * count, endpoint=False), count)
    return np.einsum("kj,kjd->kd", weights, control_points[index])


def circle_path(centre, radius):
    """A circle as four cubic Béziers, the usual way drawing programs write it."""
    x, y = centre
    k = 0.5522847498307936 * radius
    return (
        f"M {x + radius} {y} C {x + radius} {y + k} {x + k} {y + radius} {x} {y + radius} "
        f"C {x - k} {y + radius} {x - radius} {y + k} {x - radius} {y} "
        f"C {x - radius} {y - k} {x - k} {y - radius} {x} {y - radius} "
        f"C {x + k} {y - radius} {x + radius} {y - k} {x + radius} {y} Z"
    )


@pytest.mark.parametrize("cage", [read_cage(STARFISH), CORNERED], ids=["starfish", "cornered"])
def test_an_exact_chain_gives_back_its_control_points(tmp_path, cage):
    write_cage(tmp_path / "cage.svg", cage, image_size=(640, 480))
    control_points, remark = read_cage_file(tmp_path / "cage.svg")
    assert remark is None
    assert control_points.shape == cage.shape
    assert np.abs(control_points - cage).max() <= 1e-9


def test_the_written_file_is_a_q_t_chain_over_the_image():
    text = svg_text(CORNERED, 640, 480)
    assert 'width="640" height="480" viewBox="0 0 640 480"' in text
    d = text.split(' d="')[1].split('"')[0]
    # The first span and the span out of each of the two corners start a Q; the others are Ts.
    assert d.startswith("M 22.625,90.5 Q 10.25,90.5 10.25,90.5 Q 10.25,90.5 ")
    assert d.count("Q") == 3 and d.count("T") == len(CORNERED) - 3 and d.endswith(" Z")


def test_a_cubic_circle_is_fitted_within_half_a_pixel():
    cage = svg_cage(f'{SVG_HEAD}<path d="{circle_path((150, 100), 80)}"/></svg>'.encode())
    assert cage.fit_error is not None and cage.fit_error <= FIT_TOLERANCE
    radii = np.linalg.norm(curve_samples(cage.control_points) - [150, 100], axis=1)
    assert np.abs(radii - 80).max() <= FIT_TOLERANCE
    assert len(doubled_points(cage.control_points)) == 0


def test_a_polygon_keeps_its_corners_as_doubled_points():
    cage = svg_cage(f'{SVG_HEAD}<polygon points="20,20 220,20 220,120 20,170"/></svg>'.encode())
    corners = [[20, 20], [220, 20], [220, 120], [20, 170]]
    doubled = doubled_points(cage.control_points)
    assert len(doubled) == 4
    assert np.abs(np.sort(doubled, axis=0) - np.sort(np.array(corners, float), axis=0)).max() <= 0.5
    assert cage.fit_error <= FIT_TOLERANCE


def test_group_and_path_transforms_apply_and_the_viewport_does_not():
    plain = svg_text(CORNERED, 300, 200).split("<path ")[1].split("\n")[0]
    document = (
        '<svg xmlns="http://www.w3.org/2000/svg" width="30cm" height="20cm" viewBox="0 0 300 200">'
        f'<g transform="translate(12,-7) scale(2,0.5)"><path {plain}</g></svg>'
    )
    cage = svg_cage(document.encode())
    assert cage.fit_error is None
    expected = CORNERED * [2.0, 0.5] + [12.0, -7.0]
    assert np.abs(cage.control_points - expected).max() <= 1e-9


def test_the_first_closed_path_is_the_cage():
    circle = circle_path((150, 100), 40)
    document = (
        f'{SVG_HEAD}<path d="M 0 0 L 50 50 L 80 0"/><path d="{circle}"/><rect width="9" height="9"/></svg>'
    )
    radii = np.linalg.norm(curve_samples(svg_cage(document.encode()).control_points) - [150, 100], axis=1)
    assert np.abs(radii - 40).max() <= FIT_TOLERANCE


@pytest.mark.parametrize(
    "text, message",
    [
        (f'{SVG_HEAD}<path d="M 0 0 L 50 50 L 80 0"/></svg>', "no closed path in the SVG"),
        (f"{SVG_HEAD}</svg>", "no closed path in the SVG"),
        ("<svg><path", "not an SVG document"),
    ],
)
def test_a_file_without_a_closed_path_is_refused_in_one_line(tmp_path, text, message):
    (tmp_path / "open.svg").write_text(text)
    with pytest.raises(InputError) as error:
        read_cage(tmp_path / "open.svg")
    assert str(error.value).startswith(f"{tmp_path / 'open.svg'}: {message}")
    assert "\n" not in str(error.value)


def test_a_fitted_cage_says_how_closely(tmp_path):
    (tmp_path / "circle.svg").write_text(f'{SVG_HEAD}<path d="{circle_path((150, 100), 80)}"/></svg>')
    control_points, remark = read_cage_file(tmp_path / "circle.svg")
    assert remark.startswith(f"{tmp_path / 'circle.svg'}: the path is not a quadratic B-spline; fitted ")
    assert f"{len(control_points)} control points within 0." in remark


def test_a_chain_rounded_by_an_editor_is_still_read_as_its_control_points():
    """Inkscape writes 8 significant digits: the joints are then off the midpoints by rounding only."""
    import re

    cage = read_cage(STARFISH) + 0.123456789
    text = re.sub(r"\d+\.\d+", lambda m: f"{float(m.group()):.8g}", svg_text(cage, 640, 480))
    read = svg_cage(text.encode())
    assert read.fit_error is None and np.abs(read.control_points - cage).max() <= 1e-5


@pytest.mark.parametrize(
    "path, message",
    [
        ("M 1e400 0 L 1 1 L 2 0 Z", "the path's coordinates are not all finite numbers"),
        (
            "M 0 0 L 1e12 0 L 1e12 1e12 Z",
            "the path is 3,414,213,562,373 px long; a path of at most 50,000 px",
        ),
    ],
)
def test_a_path_that_cannot_be_fitted_is_refused_in_one_line(tmp_path, path, message):
    (tmp_path / "far.svg").write_text(f'{SVG_HEAD}<path d="{path}"/></svg>')
    with pytest.raises(InputError) as error:
        read_cage(tmp_path / "far.svg")
    assert str(error.value).startswith(f"{tmp_path / 'far.svg'}: {message}")
