"""Tests of app.render.renderer and app.render.shaders on a headless EGL context.

Without EGL these tests fail (the fixture raises): rendering is never skipped.
Meshes and deformations are built here (scipy Delaunay, affine maps), so the
renderer is tested independently of core's mesher and kernels.
"""

from types import SimpleNamespace

import cv2
import numpy as np
import pytest
from scipy.spatial import Delaunay
from support.rendering import ellipse_mesh, polygon_mask, smooth_image  # noqa: F401

from app.render.passes.fields import BAND_COLOURS, BAND_START, BAND_WIDTH
from app.render.passes.image import HIGHLIGHT_COLOUR
from app.render.renderer import View, WarpRenderer, create_headless_context
from app.render.shaders import load_shader


def psnr(a, b, mask):
    error = np.mean((a[mask][:, :3].astype(np.float64) - b[mask][:, :3]) ** 2)
    return 10 * np.log10(255.0**2 / max(error, 1e-12))


def affine(matrix, offset, points):
    return points @ np.asarray(matrix).T + offset


def rotation(angle):
    return np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])


# -- shaders ---------------------------------------------------------------------------


def test_shader_loader_caches_and_names_missing_files():
    assert load_shader("mesh.vert.glsl") is load_shader("mesh.vert.glsl")
    with pytest.raises(FileNotFoundError, match=r"shader 'nope.glsl' not found .*available: .*mesh.vert"):
        load_shader("nope.glsl")


# -- image warping ---------------------------------------------------------------------


def test_identity_on_full_rectangle_reproduces_the_image(renderer):
    image = smooth_image()
    height, width = image.shape[:2]
    y, x = np.mgrid[0:height:24j, 0:width:32j]
    vertices = np.stack([x.ravel(), y.ravel()], axis=1)
    renderer.set_image(image)
    renderer.set_mesh(vertices, Delaunay(vertices).simplices)
    out = renderer.render((width, height))
    assert out.shape == image.shape and out.dtype == np.uint8
    assert psnr(out, image, np.ones((height, width), bool)) >= 40
    assert (out[..., 3] == 255).all()


def test_identity_inside_domain_and_transparent_outside(renderer):
    image = smooth_image()
    vertices, triangles, boundary = ellipse_mesh((160, 120), (130, 90), 9)
    renderer.set_image(image)
    renderer.set_mesh(vertices, triangles)
    out = renderer.render((320, 240))
    inside = polygon_mask(boundary, (240, 320), 1.5)
    outside = polygon_mask(boundary, (240, 320), -1.5)
    assert psnr(out, image, inside) >= 40
    assert (out[inside, 3] == 255).all()
    assert (out[outside] == 0).all(), "outside the domain everything must be transparent black"


def test_affine_deformation_matches_cv2_warp_affine(renderer):
    image = smooth_image()
    height, width = image.shape[:2]
    vertices, triangles, boundary = ellipse_mesh((160, 120), (120, 80), 10)
    matrix = rotation(np.radians(17)) @ np.diag([0.85, 1.1])
    offset = np.array([30.0, -12.0])
    renderer.set_image(image)
    renderer.set_mesh(vertices, triangles)
    renderer.set_positions(affine(matrix, offset, vertices))
    out = renderer.render((width, height))
    # Our pixel (i, j) covers [i, i+1] x [j, j+1]; OpenCV's pixel centres are integers,
    # so x' = A x + b becomes i' = A i + b + (A - I) (0.5, 0.5).
    opencv_offset = offset + (matrix - np.eye(2)) @ [0.5, 0.5]
    expected = cv2.warpAffine(
        image,
        np.hstack([matrix, opencv_offset[:, None]]),
        (width, height),
        flags=cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=(0, 0, 0, 0),
    )
    inside = polygon_mask(affine(matrix, offset, boundary), (height, width), 2.0)
    assert inside.sum() > 20000
    # 33 dB is the requirement; 45 also proves the half-pixel convention (41.8 dB without it).
    assert psnr(out, expected, inside) >= 45
    assert (out[polygon_mask(affine(matrix, offset, boundary), (height, width), -1.5), 3] == 0).all()


def test_no_cracks_under_a_nonlinear_deformation(renderer):
    image = smooth_image()
    vertices, triangles, boundary = ellipse_mesh((160, 120), (120, 85), 6, seed=3)
    # A swirl: every triangle moves differently, so any gap between neighbours shows.
    relative = vertices - (160, 120)
    turn = 0.6 * np.exp(-np.sum(relative**2, axis=1) / 80.0**2)
    swirled = np.einsum("vij,vj->vi", rotation(turn).transpose(2, 0, 1), relative)
    renderer.set_image(image)
    renderer.set_mesh(vertices, triangles)
    renderer.set_positions(swirled + (160, 120))
    out = renderer.render((320, 240))
    # The boundary turns by at most ~0.6 rad near its ends; compare with the swirled boundary polygon.
    boundary_index = np.arange(len(boundary))  # ellipse_mesh puts the boundary first
    deformed_boundary = swirled[boundary_index] + (160, 120)
    inside = polygon_mask(deformed_boundary, (240, 320), 1.5)
    assert inside.sum() > 20000
    assert (out[inside, 3] == 255).all()


def test_edges_are_antialiased(renderer):
    image = smooth_image()
    square = np.array([[60.0, 40.0], [260.0, 40.0], [260.0, 200.0], [60.0, 200.0]])
    renderer.set_image(image)
    renderer.set_mesh(square, np.array([[0, 1, 2], [0, 2, 3]]))
    renderer.set_positions(affine(rotation(0.3), (40, -40), square))
    alpha = renderer.render((320, 240))[..., 3]
    levels = np.unique(alpha[(alpha > 0) & (alpha < 255)])
    assert len(levels) >= 3, f"edge pixels should have partial coverage, got levels {levels}"


def test_shrinking_uses_mipmaps(renderer):
    size = 512
    y, x = np.mgrid[0:size, 0:size]
    checker = np.zeros((size, size, 4), dtype=np.uint8)
    checker[..., :3] = (((x + y) % 2) * 255)[..., None]
    checker[..., 3] = 255
    corners = np.array([[0.0, 0.0], [size, 0.0], [size, size], [0.0, size]])
    renderer.set_image(checker)
    renderer.set_mesh(corners, np.array([[0, 1, 2], [0, 2, 3]]))
    # 8.3, not 8: at exactly 1/8 every sample sits on a texel edge, where even plain
    # bilinear filtering averages to grey and the test could not fail.
    out = renderer.render((61, 61), View(1 / 8.3)).astype(np.float64)
    grey = out[1:-1, 1:-1, :3]
    assert abs(grey.mean() - 127.5) < 3
    assert grey.std() < 2, "a shrunk checkerboard must come out uniform grey, not aliased"


def test_transparent_source_pixels_do_not_bleed_colour(renderer):
    # Left half: transparent with a red colour that must never show; right half: opaque blue.
    image = np.zeros((64, 64, 4), dtype=np.uint8)
    image[:, :32] = (255, 0, 0, 0)
    image[:, 32:] = (0, 0, 255, 255)
    corners = np.array([[0.0, 0.0], [64.0, 0.0], [64.0, 64.0], [0.0, 64.0]])
    renderer.set_image(image)
    renderer.set_mesh(corners, np.array([[0, 1, 2], [0, 2, 3]]))
    out = renderer.render((37, 37), View(37 / 64))  # shrink: filtering mixes both halves
    partial = (out[..., 3] > 0) & (out[..., 3] < 255)
    assert partial.any()
    assert (out[partial, 0] <= 2).all() and (out[partial, 2] >= 250).all()
    assert (out[out[..., 3] == 0, :3] == 0).all()


def test_view_maps_image_points_to_framebuffer_pixels(renderer):
    image = np.full((10, 10, 4), 255, dtype=np.uint8)
    square = np.array([[2.0, 3.0], [6.0, 3.0], [6.0, 8.0], [2.0, 8.0]])
    renderer.set_image(image)
    renderer.set_mesh(square, np.array([[0, 1, 2], [0, 2, 3]]))
    out = renderer.render((40, 30), View(2.0, (5.0, 7.0)))
    rows, columns = np.nonzero(out[..., 3] == 255)
    # (x, y) -> (5 + 2x, 7 + 2y): x in [2, 6] -> columns 9..16, y in [3, 8] -> rows 13..22.
    assert (columns.min(), columns.max(), rows.min(), rows.max()) == (9, 16, 13, 22)


def test_render_restores_the_callers_framebuffer():
    # A context of its own: the framebuffer bound here must not outlive the test.
    ctx = create_headless_context()
    screen = ctx.simple_framebuffer((8, 8))
    screen.use()
    with WarpRenderer(ctx) as renderer:
        renderer.set_image(np.full((4, 4, 4), 255, dtype=np.uint8))
        renderer.set_mesh(np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 4.0]]), np.array([[0, 1, 2]]))
        renderer.render((16, 16))
        renderer.render((32, 16))  # a new size replaces the offscreen framebuffers
        assert ctx.fbo is screen
    ctx.release()


def test_view_fit_centres_the_box():
    view = View.fit((0.0, 0.0, 200.0, 100.0), (400, 400), margin=10)
    assert view.scale == pytest.approx(1.9)
    assert view.offset == pytest.approx((10.0, 105.0))


def test_positions_update_in_place(renderer):
    image = smooth_image()
    vertices, triangles, _ = ellipse_mesh((160, 120), (100, 70), 12)
    renderer.set_image(image)
    renderer.set_mesh(vertices, triangles)
    mesh = renderer._mesh
    buffer, vertex_array = mesh.positions.glo, mesh.vaos["caller"]["image"].glo
    first = renderer.render((320, 240))
    renderer.set_positions(vertices + (20.0, 0.0))
    second = renderer.render((320, 240))
    assert (mesh.positions.glo, mesh.vaos["caller"]["image"].glo) == (buffer, vertex_array)
    # A whole-pixel move shifts the picture exactly.
    assert np.array_equal(second[:, 40:], first[:, 20:-20])


def test_screen_order_draws_the_picture_of_the_callers_order(renderer):
    """Vertices and on-screen triangles in Z-order (for speed): the same pixels wherever nothing
    folds over, and the same folded triangles found; the field follows its vertices."""
    image = smooth_image()
    vertices, triangles, _ = ellipse_mesh((160, 120), (100, 70), 6)
    renderer.set_image(image)
    renderer.set_mesh(vertices, triangles)
    screen, caller = renderer._mesh.vaos["screen"], renderer._mesh.vaos["caller"]
    assert not np.array_equal(renderer.vertex_order, np.arange(len(vertices)))  # reordered indeed
    deformed = vertices + 12.0 * np.sin(vertices[:, ::-1] / 25.0)  # smooth, nothing folds
    renderer.set_positions(deformed)
    renderer.set_field(deformed[:, 0] / 320.0)
    for content in ("image", "field", "heat"):
        expected = renderer.render((320, 240), content=content, folds=True)
        renderer._mesh.vaos["caller"] = screen
        try:
            drawn = renderer.render((320, 240), content=content, folds=True)
        finally:
            renderer._mesh.vaos["caller"] = caller
        assert np.array_equal(drawn, expected), content
    # A fold: the highlighted triangles agree between the two orders.
    folded = deformed.copy()
    folded[vertices[:, 0] > 200] *= [-1.0, 1.0]
    folded[vertices[:, 0] > 200] += [420.0, 0.0]
    renderer.set_positions(folded)
    expected = renderer.render((320, 240), content="none", folds=True, background=(1, 1, 1, 1))
    assert (expected[..., :3] < 250).any()  # something is folded
    renderer._mesh.vaos["caller"] = screen
    try:
        drawn = renderer.render((320, 240), content="none", folds=True, background=(1, 1, 1, 1))
    finally:
        renderer._mesh.vaos["caller"] = caller
    assert np.array_equal(drawn, expected)


def test_ordered_positions_are_written_as_given(renderer):
    vertices, triangles, _ = ellipse_mesh((160, 120), (100, 70), 12)
    renderer.set_image(smooth_image())
    renderer.set_mesh(vertices, triangles)
    shifted = vertices + (20.0, 0.0)
    renderer.set_positions(shifted)
    expected = renderer.render((320, 240))
    renderer.set_positions(vertices)
    renderer.set_ordered_positions(shifted[renderer.vertex_order].astype(np.float32))
    assert np.array_equal(renderer.render((320, 240)), expected)
    with pytest.raises(ValueError, match="float32"):
        renderer.set_ordered_positions(shifted)


# -- scalar fields and overlays ---------------------------------------------------------


def test_field_bands_follow_the_colour_map(renderer):
    vertices = np.array([[0.0, 0.0], [120.0, 0.0], [120.0, 40.0], [0.0, 40.0]])
    renderer.set_mesh(vertices, np.array([[0, 1, 2], [0, 2, 3]]))
    # Values off the band edges (every multiple of 0.1 carries an iso-line).
    for value, band in ((-0.55, 0), (-0.05, 0), (0.05, 1), (0.55, 6), (0.95, 10), (1.05, 11), (3.05, 11)):
        renderer.set_field(np.full(4, value))
        out = renderer.render((120, 40), content="field")
        expected = np.round(255 * BAND_COLOURS[band])
        assert np.abs(out[20, 60, :3] - expected).max() <= 1, (value, band)
    # A ramp from BAND_START to the end of the last band shows every band in order.
    renderer.set_field(BAND_START + len(BAND_COLOURS) * BAND_WIDTH * vertices[:, 0] / 120.0)
    row = renderer.render((120, 40), content="field")[20, :, :3].astype(int)
    centres = ((np.arange(len(BAND_COLOURS)) + 0.5) * 10).astype(int)
    assert np.abs(row[centres] - np.round(255 * BAND_COLOURS)).max() <= 1
    # Band edges (every 10 pixels here) are darkened lines.
    edges = np.arange(1, len(BAND_COLOURS)) * 10
    brightness = row.sum(axis=1)
    assert (brightness[edges] < 0.9 * (brightness[edges - 5] + brightness[edges + 5]) / 2).all()


def test_wireframe_and_highlighted_triangles(renderer):
    vertices = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]])
    renderer.set_mesh(vertices, np.array([[0, 1, 2], [0, 2, 3]]))
    renderer.set_field(np.full(4, 0.55))
    plain = renderer.render((100, 100), content="field").astype(int)
    renderer.set_highlighted(np.array([False, True]))
    marked = renderer.render((100, 100), content="field", wireframe=True, highlight=True).astype(int)
    # Triangle 1 (0, 2, 3) is the lower-left half (y down): (x, y) = (20, 80) is inside it.
    colour, alpha = np.array(HIGHLIGHT_COLOUR[:3]), HIGHLIGHT_COLOUR[3]
    expected = np.round(255 * colour + (1 - alpha) * plain[80, 20, :3])
    assert np.abs(marked[80, 20, :3] - expected).max() <= 2
    assert np.array_equal(marked[20, 80], plain[20, 80])
    diagonal = marked[np.arange(5, 95), np.arange(5, 95), :3].sum(axis=1)
    assert (diagonal < plain[np.arange(5, 95), np.arange(5, 95), :3].sum(axis=1)).mean() > 0.9


# -- errors -------------------------------------------------------------------------------


def test_errors_say_what_is_wrong(renderer):
    with pytest.raises(RuntimeError, match="set_mesh"):
        renderer.render((10, 10))
    with pytest.raises(ValueError, match=r"\(H, W, 4\) uint8"):
        renderer.set_image(np.zeros((4, 4, 3), dtype=np.uint8))
    with pytest.raises(ValueError, match="integer indices"):
        renderer.set_mesh(np.zeros((3, 2)), np.array([[0, 1, 3]]))
    renderer.set_mesh(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), np.array([[0, 1, 2]]))
    with pytest.raises(RuntimeError, match="set_image"):
        renderer.render((10, 10))
    with pytest.raises(ValueError, match="positions must have shape"):
        renderer.set_positions(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="mask or indices"):
        renderer.set_highlighted(np.array([1]))
    renderer.set_highlighted([])
    with pytest.raises(ValueError, match="output size"):
        renderer.render((0, 10), content="none")


@pytest.mark.parametrize("backdrop", [False, True])
def test_outputs_larger_than_a_tile_are_drawn_in_tiles_like_one_drawing(renderer, monkeypatch, backdrop):
    image = smooth_image()
    vertices, triangles, boundary = ellipse_mesh((160, 120), (120, 85), 6, seed=3)
    renderer.set_image(image)
    renderer.set_mesh(vertices, triangles)
    renderer.set_positions(affine(rotation(0.3) * 1.1, (-20, 15), vertices))
    view = View(1.3, (7.0, -4.0))
    whole = renderer.render((331, 247), view, backdrop=backdrop)
    monkeypatch.setattr("app.render.renderer.TILE", 64)  # 6 x 4 tiles, the last ones partly outside
    tiled = renderer.render((331, 247), view, backdrop=backdrop)
    difference = np.abs(tiled.astype(int) - whole).max(axis=2)
    # Only float32 rounding of the shifted view: a few texture samples, by one level.
    assert np.mean(difference == 0) > 0.95
    assert difference.max() <= 1


def test_outputs_over_the_pixel_limit_are_refused(renderer, monkeypatch):
    renderer.set_image(smooth_image(8, 8))
    renderer.set_mesh(np.array([[0.0, 0.0], [8.0, 0.0], [0.0, 8.0]]), np.array([[0, 1, 2]]))
    with pytest.raises(ValueError, match=r"output size 16384x16384 is not 1 to 134 megapixels"):
        renderer.render((16384, 16384))


@pytest.mark.parametrize("backdrop", [False, True])
def test_strips_are_the_rows_of_render_and_skip_multisampling_only_off_the_edges(renderer, backdrop):
    from app.io.images.tiles import crosses, drawn_edges

    image = smooth_image()
    vertices, triangles, boundary = ellipse_mesh((160, 120), (120, 85), 6, seed=3)
    renderer.set_image(image)
    renderer.set_mesh(vertices, triangles)
    positions = affine(rotation(0.3) * 1.1, (-20, 15), vertices)
    renderer.set_positions(positions)
    view = View(1.3, (7.0, -4.0))
    whole = renderer.render((331, 247), view, backdrop=backdrop)
    strips = list(renderer.render_strips((331, 247), view, rows=40, backdrop=backdrop))
    assert [top for top, _ in strips] == list(range(0, 247, 40))
    tiled = np.concatenate([rows for _, rows in strips])
    assert np.abs(tiled.astype(int) - whole).max() <= 1  # the tiles' shifted views, as above

    # The ellipse mesh's first vertices are its boundary, in order (core.Mesh's two fields).
    order = np.arange(len(boundary))
    mesh = SimpleNamespace(boundary=order, boundary_parameters=order.astype(float))
    edges = drawn_edges(mesh, positions, view, (160, 120), backdrop)
    plain = set()
    for top, rows in renderer.render_strips(
        (331, 247),
        view,
        rows=40,
        backdrop=backdrop,
        antialiased=lambda box: crosses(edges, box) or plain.add(box),
    ):
        difference = np.abs(rows.astype(int) - whole[top : top + len(rows)]).max(axis=2)
        assert difference.max() <= 1, top  # one unit where two triangles meet inside the warp
    assert plain  # some tiles were drawn without multisampling


def test_a_copied_drawing_lays_tiles_inside_whole_parts_along_the_outline_and_nothing_outside():
    from app.render.renderer import _drawn_parts

    corners = np.array([[100.0, 100.0], [400.0, 100.0], [400.0, 400.0], [100.0, 400.0]])
    square = np.stack([corners, np.roll(corners, -1, axis=0)], axis=1)
    assert list(_drawn_parts(square, (200, 200, 300, 300), (64, 64))) == [((200, 200, 300, 300), False)]
    assert list(_drawn_parts(square, (500, 0, 600, 100), (64, 64))) == []  # outside: nothing drawn
    parts = list(_drawn_parts(square, (64, 64, 192, 180), (64, 64)))  # two sides cross it
    assert parts == [
        ((64, 64, 128, 128), True),
        ((128, 64, 192, 128), True),
        ((64, 128, 128, 180), True),
        ((128, 128, 192, 180), False),  # inside, away from both sides
    ]
    folded = list(_drawn_parts(None, (0, 0, 100, 64), (64, 64)))  # folds: every part multisampled
    assert folded == [((0, 0, 64, 64), True), ((64, 0, 100, 64), True)]


def test_copied_drawings_of_other_kinds_one_after_another_keep_their_framebuffers(renderer):
    vertices, triangles, _ = ellipse_mesh((160, 120), (120, 85), 6, seed=3)
    opaque = smooth_image()
    translucent = opaque.copy()
    translucent[..., 3] = 200
    for image in (opaque, translucent, opaque):  # an 8-bit translucent image draws in 16 bits
        renderer.set_image(image)
        renderer.set_mesh(vertices, triangles)
        renderer.set_positions(affine(rotation(0.2), (5, -3), vertices))
        pixels = renderer.render((160, 120), backdrop=True)
        assert (pixels[..., 3] == image[0, 0, 3]).mean() > 0.5


@pytest.mark.parametrize("shrink", [1.0, 0.6])  # 0.6: the drawing samples the mipmaps
@pytest.mark.parametrize("translucent", [False, True])
def test_a_copied_drawing_from_a_texture_of_the_box_it_samples_is_the_whole_images(
    renderer, monkeypatch, shrink, translucent
):
    import app.render.renderer as renderer_module

    image = smooth_image(640, 512, seed=4)
    if translucent:
        image[..., 3] = np.random.default_rng(4).integers(1, 256, image.shape[:2])
    vertices, triangles, _ = ellipse_mesh((300, 260), (120, 90), 9, seed=5)
    positions = affine(rotation(0.25) * shrink, (40, 20), vertices - (300, 260)) + (300, 260)
    renderer.set_image(image)
    renderer.set_mesh(vertices, triangles)
    renderer.set_positions(positions)
    boxed = renderer.render((640, 512), backdrop=True)
    assert renderer._textures["box"].box == (64, 64, 512, 448)
    monkeypatch.setattr(renderer_module, "sampled_box", lambda *arguments: None)  # the whole image
    renderer.set_image(image)
    whole = renderer.render((640, 512), backdrop=True)
    assert "box" not in renderer._textures
    difference = np.abs(boxed.astype(int) - whole)
    assert difference.max() <= 1  # the texture's coordinate rounded otherwise: a unit, rarely
    assert (difference.max(axis=2) > 0).mean() < 0.01


def test_a_warp_drawn_in_place_is_the_copys_pixels_in_the_images_own_array(renderer):
    image = smooth_image(200, 160, seed=2)
    vertices, triangles, _ = ellipse_mesh((100, 80), (60, 45), 6, seed=1)
    positions = affine(rotation(0.2), (6, -4), vertices - (100, 80)) + (100, 80)

    def drawn(**options):
        mine = image.copy()
        renderer.set_image(mine)
        renderer.set_mesh(vertices, triangles)
        renderer.set_positions(positions)
        return mine, renderer.render((200, 160), backdrop=True, **options)

    _, copied = drawn()
    mine, in_place = drawn(in_place=True)
    assert in_place is mine
    np.testing.assert_array_equal(in_place, copied)
    with pytest.raises(RuntimeError, match="set_image first"):  # the renderer let go of it
        renderer.render((200, 160), backdrop=True)
    for options in ({"background": (1.0, 1.0, 1.0, 1.0)}, {"view": View(1.0, (1.0, 0.0))}):
        mine, pixels = drawn(in_place=True, **options)
        assert pixels is not mine and np.array_equal(mine, image)  # not the image's frame: a copy


def test_a_tile_draws_its_triangles_those_that_shrink_nothing_without_mipmaps_the_same(renderer, monkeypatch):
    import app.render.passes.image as image_pass

    image = smooth_image(800, 600, seed=6)
    vertices, triangles, _ = ellipse_mesh((400, 300), (300, 220), 12, seed=2)
    moved = vertices.copy()
    left = vertices[:, 0] < 400
    moved[left, 0] = 400 - (400 - vertices[left, 0]) * 0.7  # the left half shrunk, the right moved
    moved[~left, 0] += 3.0
    renderer.set_image(image)
    renderer.set_mesh(vertices, triangles)
    renderer.set_positions(moved)
    drawn = []
    original = image_pass.ImagePass.draw_image

    def spied(self, *arguments, **options):
        drawn.append(options.get("split"))
        return original(self, *arguments, **options)

    monkeypatch.setattr(image_pass.ImagePass, "draw_image", spied)
    divided = renderer.render((800, 600), backdrop=True)
    splits = [split for split in drawn if split is not None]
    shrinking = splits[0][0]
    assert 0.2 < shrinking.mean() < 0.8  # some through the mipmaps, some not
    assert any(shown.mean() < 1 for _, shown in splits)  # a part draws the triangles it may show
    assert np.logical_or.reduce([shown for _, shown in splits]).all()

    def unsplit(self, *arguments, **options):
        return original(self, *arguments, **dict(options, split=None))

    monkeypatch.setattr(image_pass.ImagePass, "draw_image", unsplit)
    whole = renderer.render((800, 600), backdrop=True)
    difference = np.abs(divided.astype(int) - whole)
    assert difference.max() <= 1 and (difference.max(axis=2) > 0).mean() < 1e-3
