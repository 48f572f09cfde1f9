"""Where an animation's frames go (app.warp.frame_writers): the GIF written as its frames come."""

import numpy as np
from PIL import Image, ImageSequence

from app.warp.frame_writers import BACKGROUND, GifWriter, check_frames, flatten


def opaque(rgb: np.ndarray) -> np.ndarray:
    return np.dstack([rgb, np.full(rgb.shape[:2], 255)]).astype(np.uint8)


def test_flatten_copies_opaque_pixels_and_rounds_the_blend_of_the_others():
    rng = np.random.default_rng(11)
    rgba = rng.integers(0, 256, (40, 50, 4)).astype(np.uint8)
    rgba[:10, ..., 3] = 255
    alpha = rgba[..., 3:4].astype(np.int64)
    exact = rgba[..., :3] * alpha + np.asarray(BACKGROUND) * (255 - alpha)  # 255 x the blend
    expected = (2 * exact + 255) // 510  # rounded, halves up
    np.testing.assert_array_equal(flatten(rgba), expected)
    np.testing.assert_array_equal(flatten(rgba)[:10], rgba[:10, ..., :3])
    sixteen = rgba.astype(np.uint16) * 257
    np.testing.assert_array_equal(flatten(sixteen), expected)


def test_a_gif_maps_every_frame_to_one_palette_and_encodes_only_what_changed(tmp_path):
    rng = np.random.default_rng(4)
    # 48 patches of colour, fewer than the palette's 256 colours.
    base = np.kron(rng.integers(0, 256, (6, 8, 3)), np.ones((10, 10, 1))).astype(np.uint8)
    frames = []
    for step in range(4):
        frame = base.copy()
        frame[10 + 5 * step : 20 + 5 * step, 30:45] = (255, 0, 0)
        frames.append(frame)
    frames.insert(2, frames[1])  # held for a frame: the delay of its first showing grows
    writer = GifWriter(tmp_path / "out.gif", (80, 60), 10.0)
    picks = writer.lookahead(len(frames))
    assert picks == [0, 1, 2, 3, 4]
    for index in picks:
        writer.preview(opaque(frames[index]))
    for frame in frames:
        writer.add(opaque(frame))
    writer.finish()
    assert [path.name for path in tmp_path.iterdir()] == ["out.gif"]  # no temporary left
    with Image.open(tmp_path / "out.gif") as gif:
        shown, boxes, delays = [], [], []
        for frame in ImageSequence.Iterator(gif):
            boxes.append(frame.dispose_extent)
            delays.append(frame.info["duration"])
            shown.append(np.asarray(frame.convert("RGB")))
    assert delays == [100, 200, 100, 100]
    assert boxes[0] == (0, 0, 80, 60) and boxes[1] == (30, 10, 45, 25)  # rows 10..24: the old and new red
    assert all(box == (30, 15 + 5 * k, 45, 30 + 5 * k) for k, box in enumerate(boxes[2:]))
    # 49 colours in all: the palette holds each, and every frame comes back exactly, whole.
    for frame, drawn in zip([frames[0], frames[1], frames[3], frames[4]], shown, strict=True):
        np.testing.assert_array_equal(drawn, frame)


def test_a_gif_over_its_cap_is_refused(tmp_path, monkeypatch):
    monkeypatch.setattr("app.warp.frame_writers.MAX_GIF_BYTES", 3 * 100 * 100 * 10)
    check_frames("gif", 10, (100, 100), tmp_path / "out.gif")
    check_frames("png", 11, (100, 100), tmp_path / "frames")
    try:
        check_frames("gif", 11, (100, 100), tmp_path / "out.gif")
    except ValueError as error:
        assert str(error) == (
            f"{tmp_path / 'out.gif'}: 11 frames of 100x100 are too many for a GIF; "
            "write an MP4 or PNG frames, or give a smaller --size or --fps"
        )
    else:
        raise AssertionError("11 frames over the cap were accepted")
