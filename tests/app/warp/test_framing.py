"""What an export shows (app.warp.framing) and the renderer's backdrop (``--outside original``)."""

import numpy as np
import pytest
from support.rendering import ellipse_mesh, polygon_mask, smooth_image

from app.render.viewport import View
from app.viewer.editing import curve_points
from app.warp.framing import output_frame, output_region

SQUARE = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]])


def test_source_canvas_is_the_image_and_grow_holds_the_whole_target():
    assert output_region((320, 240), SQUARE + 500, "source") == (0.0, 0.0, 320.0, 240.0)
    assert output_region((320, 240), SQUARE + 10, "grow") == (0.0, 0.0, 320.0, 240.0)  # inside already
    target = SQUARE * [2.0, 1.0] + [-60.5, 180.0]
    x0, y0, x1, y1 = output_region((320, 240), target, "grow")
    curve = curve_points(target, 200)
    assert x0 <= curve[:, 0].min() < x0 + 1 and y1 - 1 < curve[:, 1].max() <= y1
    assert (x0, y0, x1) == (-61.0, 0.0, 320.0)  # whole pixels, and the image stays in
    with pytest.raises(ValueError, match="canvas must be one of source, grow"):
        output_region((320, 240), SQUARE, "huge")


def test_output_frame_maps_the_region_onto_the_output():
    region = (-61.0, -5.0, 320.0, 240.0)
    size, view = output_frame(region)
    assert size == (381, 245) and view == View(1.0, (61.0, 5.0))
    size, view = output_frame(region, scale=0.5)
    assert size == (190, 122) and view.scale == 0.5
    np.testing.assert_allclose(np.asarray(view.offset) + 0.5 * np.array([-61.0, -5.0]), 0.0)
    size, view = output_frame((0.0, 0.0, 320.0, 240.0), size=(160, 160))
    assert size == (160, 160) and view.scale == 0.5


def test_outside_original_keeps_the_picture_and_draws_the_warp_over_it(renderer):
    image = smooth_image(320, 240)
    vertices, triangles, boundary = ellipse_mesh((150.0, 120.0), (60.0, 45.0), 8.0)
    renderer.set_image(image)
    renderer.set_mesh(vertices, triangles)
    renderer.set_positions(vertices)  # identity: the input comes back, opaque
    identity = renderer.render((320, 240), backdrop=True)
    assert (identity[..., 3] == 255).all()
    # Texture coordinates interpolated to pixel centres: bilinear weights off by rounding at most.
    assert np.abs(identity[..., :3].astype(int) - image[..., :3]).max() <= 1
    shift = np.array([40.0, 20.0])
    renderer.set_positions(vertices + shift)
    moved = renderer.render((320, 240), backdrop=True)
    away = polygon_mask(boundary, image.shape[:2], -3) & polygon_mask(boundary + shift, image.shape[:2], -3)
    assert away.sum() > 50_000
    np.testing.assert_array_equal(moved[away.astype(bool)], image[away.astype(bool)])  # exactly the input
    inside = polygon_mask(boundary + shift, image.shape[:2], 3).astype(bool)
    ys, xs = np.nonzero(inside)
    source = image[ys - 20, xs - 40]
    assert np.abs(moved[ys, xs, :3].astype(int) - source[:, :3]).mean() < 2  # the translated image
    transparent = renderer.render((320, 240))
    assert (transparent[away.astype(bool), 3] == 0).all()  # the default leaves the outside empty
