"""The untouched picture copied under the warp (issue 48 item 1): pixels away from both cages are the
input's, bit for bit, at 8 and 16 bits and with any straight alpha; an identity warp gives the input
back inside the cage too, translucent or not; the compositing helpers on their own."""

import json

import numpy as np
import pytest

from app.__main__ import main
from app.io.files import read_photo, write_image
from app.render.compositing import (
    clear_pixel,
    drawn_box,
    exact_offset,
    mipmap_levels,
    narrowed,
    sampled_box,
    texel_footprints,
    warp_laid,
    warp_over,
)
from app.render.viewport import View

WIDTH, HEIGHT = 200, 150
CAGE = np.array([[60, 40], [100, 30], [140, 45], [150, 75], [135, 110], [100, 118], [62, 108], [50, 75]])
#: Two control points moved: the warp draws near the cage and nowhere else.
TARGET = CAGE + np.array([[0, 0], [6, -4], [0, 0], [8, 3], [0, 0], [0, 0], [-5, 2], [0, 0]])


def noisy(dtype, alpha: str, seed: int = 7) -> np.ndarray:
    """RGBA (HEIGHT, WIDTH, 4) of `dtype`: colour noise over the whole range; alpha opaque, every
    level in turn (``"levels"``: at 16 bits, 30000 levels spread over the range, the lowest among
    them), or noise (``"noise"``)."""
    rng = np.random.default_rng(seed)
    maximum = np.iinfo(dtype).max
    image = rng.integers(0, maximum + 1, (HEIGHT, WIDTH, 4), dtype=np.int64).astype(dtype)
    if alpha == "opaque":
        image[..., 3] = maximum
    elif alpha == "levels":  # 0, 1, 2, ... 255 along the rows, over and over; 16 bits: 0, 2053, ...
        step = 1 if dtype == np.uint8 else 2053  # odd: every pixel its own level of 65536
        image[..., 3] = (np.arange(HEIGHT * WIDTH).reshape(HEIGHT, WIDTH) * step) % (maximum + 1)
    return image


def away_from_both_cages(margin: float = 4.0) -> np.ndarray:
    """bool (HEIGHT, WIDTH): pixels whose centres lie more than `margin` pixels outside the boxes
    of the source and target control polygons (the curves lie inside them)."""
    y, x = np.mgrid[0:HEIGHT, 0:WIDTH] + 0.5
    near = np.zeros((HEIGHT, WIDTH), bool)
    for points in (CAGE, TARGET):
        low, high = points.min(axis=0) - margin, points.max(axis=0) + margin
        near |= (x >= low[0]) & (x <= high[0]) & (y >= low[1]) & (y <= high[1])
    return ~near


def warp(tmp_path, image, output, target=TARGET, *extra):
    write_image(tmp_path / "in.png", image)
    for name, points in (("cage", CAGE), ("target", target)):
        (tmp_path / f"{name}.json").write_text(json.dumps({"control_points": np.asarray(points).tolist()}))
    argv = ["warp", str(tmp_path / "in.png"), "--cage", str(tmp_path / "cage.json")]
    argv += ["--target", str(tmp_path / "target.json"), "--output", str(tmp_path / output)]
    assert main([*argv, "--outside", "original", *extra]) == 0
    return read_photo(tmp_path / output).pixels


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("alpha", ["opaque", "levels", "noise"])
@pytest.mark.parametrize("output", ["out.png", "out.tif"])
def test_pixels_away_from_both_cages_are_the_inputs_bit_for_bit(tmp_path, dtype, alpha, output):
    image = noisy(dtype, alpha)
    back = warp(tmp_path, image, output)
    away = away_from_both_cages()
    assert away.mean() > 0.5
    assert back.dtype == image.dtype
    np.testing.assert_array_equal(back[away], image[away])
    assert not np.array_equal(back, image)  # the warp drew something


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_an_identity_warp_gives_the_input_back_inside_the_cage_too(tmp_path, dtype):
    image = noisy(dtype, "opaque", seed=11)  # neighbours differ by up to the whole range
    back = warp(tmp_path, image, "out.png", CAGE)
    np.testing.assert_array_equal(back, image)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("alpha", ["levels", "noise"])
def test_an_identity_warp_of_straight_alpha_gives_the_input_back_within_a_unit(tmp_path, dtype, alpha):
    image = noisy(dtype, alpha, seed=5)
    back = warp(tmp_path, image, "out.png", CAGE).astype(int)
    # Everywhere, at every alpha (the lowest too), colour and alpha: the warp's own alpha is not
    # taken for a coverage, and the translucent picture is drawn finer than its depth.
    assert np.abs(back - image).max() <= 1


def test_a_translucent_warp_is_laid_on_the_picture_not_over_it(tmp_path):
    image = noisy(np.uint8, "levels")
    back = warp(tmp_path, image, "out.png", CAGE + (3, 2)).astype(int)  # moved by whole pixels
    # Well inside the moved cage: the picture moved, not drawn over the picture under it (a over a).
    inside = np.zeros((HEIGHT, WIDTH), bool)
    inside[55:95, 80:120] = True
    moved = np.roll(image, (2, 3), axis=(0, 1)).astype(int)
    assert np.abs(back - moved)[..., 3][inside].max() <= 1
    seen = inside & (moved[..., 3] > 0)  # a transparent pixel keeps the colour under it
    assert np.abs(back - moved)[..., :3][seen].max() <= 1
    assert (image[inside][:, 3] < 255).mean() > 0.9


def test_a_background_shows_under_transparent_pixels_and_leaves_opaque_ones(tmp_path):
    image = noisy(np.uint8, "levels")
    back = warp(tmp_path, image, "out.png", TARGET, "--background", "white")
    away = away_from_both_cages()
    opaque = away & (image[..., 3] == 255)
    np.testing.assert_array_equal(back[opaque], image[opaque])
    assert (back[away][:, 3] == 255).all()  # blended over an opaque white
    clear = away & (image[..., 3] == 0)
    assert (back[clear] == 255).all()
    # An identity warp: the picture over white inside the cage too, the warp's gaps white.
    back = warp(tmp_path, image, "out.png", CAGE, "--background", "white").astype(int)
    alpha = image[..., 3:].astype(float) / 255
    over_white = np.round(image[..., :3] * alpha + 255 * (1 - alpha))
    assert (back[..., 3] == 255).all()
    assert np.abs(back[..., :3] - over_white).max() <= 1


def test_warp_over_keeps_the_base_where_nothing_is_drawn_and_blends_where_it_partly_covers():
    base = np.array([[[10, 20, 30, 40], [200, 100, 50, 255], [0, 0, 0, 0]]], np.uint8)
    drawn = np.zeros((1, 3, 4), np.float32)
    drawn[0, 1] = (0.5, 0.25, 0.0, 0.5)  # premultiplied: straight (1, 0.5, 0) at half cover
    drawn[0, 2] = (0.2, 0.4, 0.6, 1.0)
    result = warp_over(base.copy(), drawn)
    np.testing.assert_array_equal(result[0, 0], base[0, 0])
    np.testing.assert_array_equal(result[0, 2], [51, 102, 153, 255])
    expected = np.round(np.array([0.5 + 200 / 255 * 0.5, 0.25 + 100 / 255 * 0.5, 50 / 255 * 0.5, 1.0]) * 255)
    np.testing.assert_array_equal(result[0, 1], expected)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_warp_over_a_tile_of_a_strip_is_its_blend_pixel_by_pixel_and_leaves_the_rest(dtype):
    rng = np.random.default_rng(4)
    maximum = np.iinfo(dtype).max
    strip = rng.integers(0, maximum + 1, (6, 20, 4)).astype(dtype)
    drawn = rng.integers(0, 65536, (6, 8, 4)).astype(np.uint16)
    drawn[..., 3] = np.array([0, 65535, 30000, 65535, 1, 65535, 65535, 0])  # clear, whole, partial
    drawn[..., :3] = np.minimum(drawn[..., :3], drawn[..., 3:])  # premultiplied
    if dtype == np.uint16:
        drawn = drawn.astype(np.float32) / 65535
    rows = [warp_over(strip[row : row + 1, 5:13].copy(), drawn[row : row + 1]) for row in range(6)]
    expected = np.stack(rows)
    result = strip.copy()
    warp_over(result[:, 5:13], drawn[::-1][::-1])  # a tile of a strip, GL's rows flipped twice
    np.testing.assert_array_equal(result[:, 5:13], expected[:, 0])
    rest = np.s_[5:13]
    np.testing.assert_array_equal(np.delete(result, rest, axis=1), np.delete(strip, rest, axis=1))
    whole = drawn[..., 3] >= (1.0 if dtype == np.uint16 else 65535)
    np.testing.assert_array_equal(result[:, 5:13][whole], narrowed(drawn, dtype)[whole])


def test_sixteen_bit_drawings_are_narrowed_to_the_nearest_eight_bit_sample():
    every = np.arange(65536, dtype=np.uint16).reshape(128, 128, 4)
    expected = np.floor(every.astype(np.float64) * 255 / 65535 + 0.5)
    np.testing.assert_array_equal(narrowed(every, np.uint8), expected)
    np.testing.assert_array_equal(narrowed(every[::-1], np.uint8), expected[::-1])  # GL's rows, flipped
    floats = np.linspace(0.0, 1.0, 4096, dtype=np.float32).reshape(32, 32, 4)
    np.testing.assert_array_equal(narrowed(floats, np.uint16), np.floor(floats * 65535.0 + 0.5))
    assert narrowed(every, np.uint16) is every


def test_warp_laid_replaces_where_it_covers_blends_by_coverage_and_keeps_the_rest():
    base = np.array([[[10, 20, 30, 40], [200, 100, 50, 255], [0, 0, 0, 0], [90, 60, 30, 100]]], np.uint8)
    drawn = np.zeros((1, 4, 4), np.uint16)
    drawn[0, 1] = (16384, 8192, 0, 16384)  # premultiplied: straight (1, 0.5, 0) at alpha 1/4 ...
    coverage = np.array([[0, 32768, 65535, 65535]], np.uint16)  # ... over half the pixel
    drawn[0, 3] = (0, 0, 0, 0)  # the warp covers the pixel with a transparent part of the picture
    result = warp_laid(base.copy(), drawn, coverage, np.zeros(4, np.uint8)).astype(float)
    np.testing.assert_array_equal(result[0, 0], base[0, 0])
    half = 32767 / 65535  # the part of the picture under the warp that shows
    alpha = 16384 / 65535 + half
    colour = (np.array([16384, 8192, 0]) / 65535 + half * np.array([200, 100, 50]) / 255) / alpha
    np.testing.assert_array_equal(result[0, 1], np.round(np.append(colour, alpha) * 255))
    np.testing.assert_array_equal(result[0, 2], [0, 0, 0, 0])
    np.testing.assert_array_equal(result[0, 3], [90, 60, 30, 0])  # transparent: the colour under it


def test_exact_offsets_boxes_and_clear_pixels():
    assert exact_offset(View(1.0, (3.0, -2.0))) == (3, -2)
    assert exact_offset(View(1.0, (0.5, 0.0))) is None and exact_offset(View(0.5)) is None
    positions = np.array([[10.2, 5.0], [20.0, 30.7]])
    assert drawn_box(positions, (2, 0), (100, 100)) == (11, 4, 23, 32)
    assert drawn_box(positions, (200, 0), (100, 100)) is None
    np.testing.assert_array_equal(clear_pixel((1.0, 0.5, 0.0, 1.0), np.uint8), [255, 128, 0, 255])
    np.testing.assert_array_equal(clear_pixel((0.0, 0.0, 0.0, 0.0), np.uint16), [0, 0, 0, 0])


def test_texel_footprints_are_one_for_a_translation_and_the_shrinking_otherwise():
    vertices = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 4.0], [4.0, 4.0]])
    triangles = np.array([[0, 1, 2], [1, 3, 2]])
    assert texel_footprints(vertices, vertices + 7.0, triangles, 1.0).max() == pytest.approx(1.0, abs=1e-12)
    assert texel_footprints(vertices, vertices * 0.5, triangles, 1.0).max() == pytest.approx(2.0, abs=1e-12)
    assert texel_footprints(vertices, vertices * 3.0, triangles, 0.5).max() == pytest.approx(2 / 3, abs=1e-12)
    flat = vertices.copy()
    flat[:, 1] = 0.0
    assert texel_footprints(vertices, flat, triangles, 1.0).max() == float("inf")


def test_the_sampled_box_reaches_past_every_filter_on_a_grid_of_its_margin():
    vertices = np.array([[300.5, 200.0], [700.0, 260.2], [520.0, 611.0]])
    assert sampled_box(vertices, (1000, 800), 1.0) == (192, 128, 768, 704)
    assert sampled_box(vertices, (720, 650), 8.0) == (192, 128, 720, 650)  # within the image
    assert sampled_box(vertices, (1000, 800), 8.5) is None  # shrunk further: the whole image
    assert sampled_box(vertices, (1000, 800), float("inf")) is None
    assert sampled_box(vertices + 2000, (1000, 800), 1.0) is None
    # GL's level log2(footprint) and the next, and one more; the sampled box reaches past level 5.
    assert [mipmap_levels(footprint) for footprint in (1.0, 1.5, 2.0, 3.9, 8.0)] == [2, 2, 3, 3, 5]
    reach = 0.71 * 8.0 + 1.5 * 2 ** mipmap_levels(8.0)
    assert reach < 64


def test_texel_footprints_are_each_triangles_and_their_maximum_the_footprint():
    vertices = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 4.0], [4.0, 4.0]])
    triangles = np.array([[0, 1, 2], [1, 3, 2]])
    moved = vertices.copy()
    moved[3] = (2.0, 2.0)  # the second triangle flattened to a line: collapsed
    np.testing.assert_allclose(
        texel_footprints(vertices, vertices * 0.5, triangles, 1.0), [2.0, 2.0], atol=1e-12
    )
    footprints = texel_footprints(vertices, moved, triangles, 1.0)
    assert footprints[0] == pytest.approx(1.0, abs=1e-12) and footprints[1] == float("inf")
    assert footprints.max() == float("inf")
    assert texel_footprints(vertices, vertices, triangles[:0], 1.0).shape == (0,)
