"""app.warp.fill: the subject's original position filled behind the warp, in the viewer and in warp --fill."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from support.paths import ROOT

from app.__main__ import main
from app.io.files import InputError, read_cage, read_image
from app.io.session import read_session
from app.warp.fill import (
    INPAINT_PIXELS,
    MARGIN,
    cage_mask,
    checked_fill,
    colour_of,
    filled_image,
)

ASSETS = ROOT / "assets"
#: A square cage (every point doubled: a polygon) from (20, 30) to (60, 70).
SQUARE = np.repeat(np.array([[20.0, 30.0], [60.0, 30.0], [60.0, 70.0], [20.0, 70.0]]), 2, axis=0)


def test_fills_are_names_or_colours():
    assert [checked_fill(value) for value in ("none", "transparent", "inpaint")] == [
        "none",
        "transparent",
        "inpaint",
    ]
    assert checked_fill("#FFaa00") == "#ffaa00"
    assert colour_of("#ffaa00") == (255, 170, 0, 255) and colour_of("#ffaa0080") == (255, 170, 0, 128)
    for bad in ("blue", "#fff", "#ggggggg", "", None, 3):
        with pytest.raises(InputError, match="--fill: must be none, transparent, inpaint or a colour"):
            checked_fill(bad)


def test_the_mask_is_the_inside_of_the_curve_and_a_margin():
    mask = cage_mask(SQUARE, (100, 80))
    rows, columns = np.nonzero(mask)
    # Pixel (row, column) has its centre at (column + 0.5, row + 0.5): the square holds columns 20..59
    # and rows 30..69; the margin reaches MARGIN beyond, give or take the pixel cv2's fill rounds to.
    assert 20 - MARGIN - 1 <= columns.min() <= 20 - MARGIN and 59 + MARGIN <= columns.max() <= 60 + MARGIN
    assert 30 - MARGIN - 1 <= rows.min() <= 30 - MARGIN and 69 + MARGIN <= rows.max() <= 70 + MARGIN
    assert mask[30:70, 20:60].all() and not mask[:25].any() and not mask[:, 65:].any()


def test_filled_images_change_only_the_masked_pixels():
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, (100, 80, 4), dtype=np.uint8)
    mask = cage_mask(SQUARE, image.shape[:2])
    assert filled_image(image, SQUARE, "none") is None
    for fill, inside in (("transparent", (0, 0, 0, 0)), ("#102030", (16, 32, 48, 255))):
        filled = filled_image(image, SQUARE, fill)
        assert (filled[mask] == inside).all()
        np.testing.assert_array_equal(filled[~mask], image[~mask])


@pytest.mark.parametrize("scale", [1, 10])  # 10: more than INPAINT_PIXELS, inpainted at a lower resolution
def test_inpainting_continues_the_surroundings(scale):
    # A grey picture with a red subject: inpainted, the subject's place is grey again.
    image = np.full((100 * scale, 80 * scale, 4), (90, 120, 150, 255), np.uint8)
    image[35 * scale : 65 * scale, 25 * scale : 55 * scale] = (250, 0, 0, 255)
    filled = filled_image(image, SQUARE * scale, "inpaint")
    mask = cage_mask(SQUARE * scale, image.shape[:2])
    assert (mask.sum() > INPAINT_PIXELS) == (scale > 1)
    error = np.abs(filled[mask].astype(int) - (90, 120, 150, 255))
    # Telea's method drifts by a few levels on a flat colour (more at a lower resolution); the red
    # subject left behind would be 160 or more away.
    assert error.max() <= (6 if scale == 1 else 16) and error.mean() <= (1.5 if scale == 1 else 4.0)
    np.testing.assert_array_equal(filled[~mask], image[~mask])


@pytest.mark.parametrize("scale", [1, 10])
def test_a_16_bit_picture_is_filled_at_its_depth(scale):
    """Colours scaled to 16 bits (255 -> 65535); inpainting channel by channel (cv2.inpaint takes
    16 bits in one channel only), as close to the surroundings as the 8-bit test."""
    grey = np.array((90, 120, 150, 255)) * 257
    image = np.empty((100 * scale, 80 * scale, 4), np.uint16)
    image[...] = grey
    image[35 * scale : 65 * scale, 25 * scale : 55 * scale] = (65535, 0, 0, 65535)
    mask = cage_mask(SQUARE * scale, image.shape[:2])
    coloured = filled_image(image, SQUARE * scale, "#102030")
    assert coloured.dtype == np.uint16 and (coloured[mask] == (16 * 257, 32 * 257, 48 * 257, 65535)).all()
    filled = filled_image(image, SQUARE * scale, "inpaint")
    assert filled.dtype == np.uint16
    error = np.abs(filled[mask].astype(int) - grey)
    assert error.max() <= 257 * (6 if scale == 1 else 16) and error.mean() <= 257 * (
        1.5 if scale == 1 else 4.0
    )
    np.testing.assert_array_equal(filled[~mask], image[~mask])


def viewer_state(tmp_path: Path, fill: str):
    """The viewer's state on the starfish with its top arm pulled far out, outside = original."""
    from app.viewer.state import AppState, Document, History, Snapshot

    cage = read_cage(ASSETS / "starfish.cage.json")
    target = cage.copy()
    target[:4] += [140.0, 60.0]  # the top arm moved away: its original position shows
    snapshot = Snapshot((ASSETS / "starfish.png").resolve(), cage, target)
    state = AppState(
        Document(History(snapshot), snapshot, read_image(ASSETS / "starfish.png"), tmp_path / "s.json")
    )
    from app.viewer import commands

    commands.command(state, "outside", "original")
    commands.command(state, "fill", fill)
    return state


@pytest.mark.parametrize("fill", ["inpaint", "#20c040"])
def test_the_viewers_export_and_warp_fill_write_the_same_pixels(renderer, tmp_path, fill):
    from app.viewer.documents import save
    from app.viewer.precompute import compute, make_request, result_from_message
    from app.viewer.scene import Scene
    from app.warp.framing import output_frame, output_region
    from app.warp.pipeline import render

    state = viewer_state(tmp_path, fill)
    assert state.document.fill == fill and not state.status.message_is_error
    max_edge = 12.0
    request = make_request(state.document.live, max_edge)
    state.compute.basis = result_from_message(request.key, compute(request))
    scene = Scene(renderer)
    scene.sync(state)
    # The viewer's export (app.viewer.exports.Exporter.render_still): the scene's renderer.
    height, width = state.document.image.shape[:2]
    size, view = output_frame(
        output_region((width, height), state.document.live.target, state.document.canvas)
    )
    viewer_pixels = render(
        renderer, scene.deformation(state), state.document.live.target, size, view, state.document.outside
    )
    save(state, max_edge)
    assert read_session(state.document.session_path).output.fill == fill
    plain = render(renderer, scene.deformation(state), state.document.live.target, size, view, "transparent")

    def warp(*arguments) -> np.ndarray:
        # The command itself (`python -m app warp`'s main), in this process: its own start is
        # tested in tests/app/commands/test_cli.py.
        output = tmp_path / f"warp-{len(arguments)}.png"
        assert main(["warp", *arguments, "--output", str(output)]) == 0
        return read_image(output)

    from_session = warp("--session", str(state.document.session_path))
    cage, target = tmp_path / "cage.json", tmp_path / "target.json"
    cage.write_text(json.dumps({"control_points": state.document.live.cage.tolist()}))
    target.write_text(json.dumps({"control_points": state.document.live.target.tolist()}))
    from_options = warp(
        str(ASSETS / "starfish.png"), "--cage", str(cage), "--target", str(target),
        "--max-edge", str(max_edge), "--outside", "original", "--fill", fill,
    )  # fmt: skip
    np.testing.assert_array_equal(viewer_pixels, from_session)
    np.testing.assert_array_equal(viewer_pixels, from_options)
    # And the fill shows: where the arm was and the warp is not, the original subject is gone.
    mask = cage_mask(state.document.live.cage, (height, width)) & (plain[..., 3] == 0)
    original = state.document.image[mask].astype(int)
    assert np.abs(viewer_pixels[mask].astype(int) - original).mean() > 20
    if fill.startswith("#"):
        assert (viewer_pixels[mask] == colour_of(fill)).all()


def test_warp_fill_needs_outside_original_and_a_valid_value(tmp_path, capfd):
    # In-process: the exit code and the one line are main's (test_cli runs a bad input end to end).
    for extra, message in (
        (
            ["--fill", "inpaint"],
            "--fill fills the original position behind the warp: give --outside original",
        ),
        (["--outside", "original", "--fill", "mauve"], "--fill: must be none, transparent, inpaint"),
    ):
        argv = [
            "warp",
            "--session",
            str(ASSETS / "starfish.session.json"),
            "--output",
            str(tmp_path / "out.png"),
        ]
        code = main([*argv, *extra])
        _, err = capfd.readouterr()
        assert code == 2 and message in err and err.count("\n") == 1
        assert not (tmp_path / "out.png").exists()
