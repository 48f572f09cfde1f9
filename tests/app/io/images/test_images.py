"""Photographs (issue 36): depth, EXIF orientation, ICC profile and EXIF kept, formats by extension.

The unit tests need no GL; the end-to-end tests run ``warp`` in-process on a headless
context, with procedural 16-bit images and files made with Pillow.
"""

import io
import json
import re
import struct

import cv2
import numpy as np
import pytest
from PIL import Image, ImageCms, ImageOps

from app.__main__ import main
from app.io.files import InputError, read_photo, write_image, write_png_strips
from app.io.images import ImageMetadata, encode_image, oriented
from app.io.images.colours import parse_colour
from app.io.images.metadata import exif_orientation, read_metadata
from app.io.images.writing import opaque

WIDTH, HEIGHT = 96, 64
CAGE = [[10, 8], [48, 4], [86, 10], [90, 32], [84, 56], [48, 60], [12, 54], [6, 32]]


def srgb_profile() -> bytes:
    return ImageCms.ImageCmsProfile(ImageCms.createProfile("sRGB")).tobytes()


def gradient16(alpha: bool = False) -> np.ndarray:
    """RGBA uint16 (HEIGHT, WIDTH, 4): three gradients using the low byte too; alpha a ramp or opaque."""
    y, x = np.mgrid[0:HEIGHT, 0:WIDTH]
    image = np.empty((HEIGHT, WIDTH, 4), np.uint16)
    image[..., 0] = x * 65535 // (WIDTH - 1)
    image[..., 1] = y * 65535 // (HEIGHT - 1)
    image[..., 2] = (x * 977 + y * 4099) % 65536
    image[..., 3] = 65535 if not alpha else 20000 + x * 45535 // (WIDTH - 1)
    return image


def exif_with_orientation(orientation: int) -> bytes:
    exif = Image.Exif()
    exif[0x0112] = orientation
    exif[0x010F] = "camera maker"
    return exif.tobytes()


# -- orientation and metadata -------------------------------------------------------


@pytest.mark.parametrize("orientation", range(1, 9))
def test_oriented_matches_pillows_exif_transpose(orientation):
    raw = np.random.default_rng(orientation).integers(0, 256, (5, 7, 3), dtype=np.uint8)
    image = Image.fromarray(raw)
    exif = image.getexif()
    exif[0x0112] = orientation
    image.info["exif"] = exif.tobytes()
    expected = np.asarray(ImageOps.exif_transpose(image))
    np.testing.assert_array_equal(oriented(raw, orientation), expected)


def test_orientation_is_reset_to_1_and_the_rest_of_the_exif_kept():
    block = exif_with_orientation(6)
    info = read_metadata(_jpeg_bytes(np.zeros((4, 6, 3), np.uint8), exif=block))
    assert info.orientation == 6
    assert exif_orientation(info.metadata.exif)[0] == 1
    assert b"camera maker" in info.metadata.exif


@pytest.mark.parametrize(
    ("exif", "note"),
    [
        (exif_with_orientation(9), r"orientation 9 is not one of 1-8"),
        (b"Exif\x00\x00II*\x00\xff\xff\x00\x00", r"EXIF block is malformed"),
    ],
)
def test_bad_exif_is_a_note_and_orientation_1(exif, note):
    info = read_metadata(_jpeg_bytes(np.zeros((4, 6, 3), np.uint8), exif=exif))
    assert info.orientation == 1
    assert len(info.notes) == 1 and re.search(note, info.notes[0])


def _jpeg_bytes(rgb, **options) -> bytes:
    stream = io.BytesIO()
    Image.fromarray(rgb).save(stream, format="JPEG", quality=95, **options)
    return stream.getvalue()


# -- reading and writing --------------------------------------------------------------


@pytest.mark.parametrize("extension", [".png", ".tif", ".tiff", ".jpg", ".jpeg", ".webp"])
def test_every_extension_writes_a_file_read_back_at_the_same_size(tmp_path, extension):
    image = gradient16()
    write_image(tmp_path / f"out{extension}", image)
    back = read_photo(tmp_path / f"out{extension}").pixels
    assert back.shape == image.shape
    expected_depth = np.uint16 if extension in (".png", ".tif", ".tiff") else np.uint8
    assert back.dtype == expected_depth
    if back.dtype == np.uint16:
        np.testing.assert_array_equal(back, image)  # lossless, 16 bits kept


@pytest.mark.parametrize("extension", [".png", ".tif", ".webp"])
def test_alpha_survives_the_formats_that_have_it(tmp_path, extension):
    image = gradient16(alpha=True)
    write_image(tmp_path / f"out{extension}", image)
    back = read_photo(tmp_path / f"out{extension}").pixels
    scale = 1 if back.dtype == np.uint16 else 257
    assert np.abs(back[..., 3].astype(int) * scale - image[..., 3]).max() <= 128 * (scale > 1)


@pytest.mark.parametrize("extension", [".png", ".jpg", ".tif", ".webp"])
def test_icc_profile_round_trips_byte_for_byte(tmp_path, extension):
    profile = srgb_profile()
    image = gradient16()
    write_image(tmp_path / f"out{extension}", image, ImageMetadata(icc_profile=profile))
    assert read_photo(tmp_path / f"out{extension}").metadata.icc_profile == profile
    assert Image.open(tmp_path / f"out{extension}").info["icc_profile"] == profile  # others see it too


def test_exif_is_written_to_png_jpeg_and_webp(tmp_path):
    block = exif_with_orientation(1).removeprefix(b"Exif\x00\x00")
    for extension in (".png", ".jpg", ".webp"):
        write_image(tmp_path / f"out{extension}", gradient16(), ImageMetadata(exif=block))
        assert read_photo(tmp_path / f"out{extension}").metadata.exif == block


def camera_exif() -> bytes:
    """A big-endian EXIF block, without its prefix: first IFD, Exif and GPS sub-IFDs, maker's notes."""
    exif = Image.Exif()
    exif[0x010F], exif[0x0110], exif[0x0112] = "camera maker", "model X", 1
    exif[0x0131] = "a program's name longer than four bytes"
    sub = exif.get_ifd(0x8769)
    sub[0x9003], sub[0x829A], sub[0x927C] = "2024:01:02 03:04:05", (1, 250), b"private" * 3
    gps = exif.get_ifd(0x8825)
    gps[1], gps[2] = "N", (52.0, 31.0, 12.5)
    block = exif.tobytes().removeprefix(b"Exif\x00\x00")
    assert block[:2] == b"MM"  # the TIFF that OpenCV writes is little-endian: every value is laid out anew
    return block


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_exif_is_written_into_a_tiff_with_its_offsets_relocated(tmp_path, dtype):
    image = gradient16(alpha=True) if dtype == np.uint16 else (gradient16(alpha=True) >> 8).astype(np.uint8)
    profile = srgb_profile()
    write_image(tmp_path / "out.tif", image, ImageMetadata(icc_profile=profile, exif=camera_exif()))
    np.testing.assert_array_equal(read_photo(tmp_path / "out.tif").pixels, image)
    with Image.open(tmp_path / "out.tif") as written:
        exif = written.getexif()
        assert written.info["icc_profile"] == profile and written.tag_v2[338] == (2,)
        assert (exif[0x010F], exif[0x0110], exif[0x0112]) == ("camera maker", "model X", 1)
        assert exif[0x0131] == "a program's name longer than four bytes"
        # The maker's notes may hold offsets into the file they came from: dropped.
        assert dict(exif.get_ifd(0x8769)) == {0x9003: "2024:01:02 03:04:05", 0x829A: (1, 250)}
        assert dict(exif.get_ifd(0x8825)) == {1: "N", 2: (52.0, 31.0, 12.5)}
        assert written.size == (WIDTH, HEIGHT) and written.tag_v2[256] == WIDTH  # its own sizes kept
    # Read back, a TIFF's EXIF is its first IFD's tags but those laying out its pixels.
    exif = Image.Exif()
    exif.load(b"Exif\x00\x00" + read_photo(tmp_path / "out.tif").metadata.exif)
    assert {tag: exif[tag] for tag in (0x010F, 0x0110, 0x0112)} == {
        0x010F: "camera maker",
        0x0110: "model X",
        0x0112: 1,
    }
    assert not {256, 257, 258, 273, 279, 338, 34675} & set(exif)
    assert dict(exif.get_ifd(0x8769)) == {0x9003: "2024:01:02 03:04:05", 0x829A: (1, 250)}
    assert dict(exif.get_ifd(0x8825)) == {1: "N", 2: (52.0, 31.0, 12.5)}


def test_a_malformed_exif_block_leaves_a_tiff_without_it(tmp_path):
    image = gradient16()
    write_image(tmp_path / "out.tif", image, ImageMetadata(exif=b"MM\x00*\x00\x00\xff\xff"))
    np.testing.assert_array_equal(read_photo(tmp_path / "out.tif").pixels, image)
    with Image.open(tmp_path / "out.tif") as written:
        assert 0x010F not in written.getexif()


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_a_png_written_in_strips_reads_back_exactly_with_its_metadata(tmp_path, dtype):
    image = gradient16(alpha=True) if dtype == np.uint16 else (gradient16(alpha=True) >> 8).astype(np.uint8)
    metadata = ImageMetadata(
        icc_profile=srgb_profile(), exif=exif_with_orientation(1).removeprefix(b"Exif\x00\x00")
    )
    strips = [(top, image[top : top + 10]) for top in range(0, HEIGHT, 10)]
    write_png_strips(tmp_path / "strips.png", (WIDTH, HEIGHT), dtype, iter(strips), metadata)
    back = read_photo(tmp_path / "strips.png")
    np.testing.assert_array_equal(back.pixels, image)
    assert back.metadata == metadata


def test_png_without_metadata_is_opencvs_own():
    image = (gradient16() >> 8).astype(np.uint8)
    ok, expected = cv2.imencode(".png", cv2.cvtColor(image, cv2.COLOR_RGBA2BGRA))
    assert ok and encode_image(image, "PNG") == expected.tobytes()


def test_transparent_jpeg_is_refused_and_nothing_written(tmp_path):
    with pytest.raises(InputError, match=r"out.jpg: JPEG has no transparency"):
        write_image(tmp_path / "out.jpg", gradient16(alpha=True))
    assert not (tmp_path / "out.jpg").exists()


def test_grey_palette_and_cmyk_inputs_become_rgba(tmp_path):
    grey = np.arange(24, dtype=np.uint8).reshape(4, 6) * 10
    rgb = Image.fromarray(np.stack([grey, grey[::-1], 255 - grey], -1))
    pictures = {
        "grey.png": Image.fromarray(grey),
        "grey-alpha.png": Image.fromarray(grey).convert("LA"),
        "palette.png": rgb.convert("P"),
        "cmyk.jpg": rgb.convert("CMYK"),
    }
    for name, picture in pictures.items():
        picture.save(tmp_path / name, quality=100)
        pixels = read_photo(tmp_path / name).pixels
        assert pixels.shape == (4, 6, 4) and pixels.dtype == np.uint8, name
        expected = np.asarray(picture.convert("RGB")).astype(int)
        tolerance = 6 if name.endswith(".jpg") else 0  # CMYK JPEG: lossy, converted by another decoder
        assert np.abs(pixels[..., :3].astype(int) - expected).max() <= tolerance, name


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("white", (1, 1, 1, 1)),
        ("#f00", (1, 0, 0, 1)),
        ("#00000080", (0, 0, 0, 128 / 255)),
        ("0,255,0", (0, 1, 0, 1)),
    ],
)
def test_colours(text, expected):
    assert parse_colour(text) == pytest.approx(expected)


@pytest.mark.parametrize("text", ["", "#12", "1,2", "300,0,0", "mauve", "#ggg"])
def test_bad_colours(text):
    with pytest.raises(ValueError, match="is not a colour; write a name"):
        parse_colour(text)


# -- warp end to end ----------------------------------------------------------------


def warp(tmp_path, image_name, output_name, *extra, cage=CAGE):
    (tmp_path / "cage.json").write_text(json.dumps({"control_points": cage}))
    argv = ["warp", str(tmp_path / image_name), "--cage", str(tmp_path / "cage.json")]
    argv += ["--target", str(tmp_path / "cage.json"), "--output", str(tmp_path / output_name), *extra]
    return main(argv)


@pytest.mark.parametrize("extension", [".png", ".tif"])
def test_identity_warp_of_16_bits_gives_the_input_back(tmp_path, extension):
    image = gradient16()
    write_image(tmp_path / f"in{extension}", image)
    assert warp(tmp_path, f"in{extension}", f"out{extension}", "--outside", "original") == 0
    back = read_photo(tmp_path / f"out{extension}").pixels
    assert back.dtype == np.uint16
    # The bound is 16/65535; the texture sampled at texel centres through the mesh's
    # interpolated coordinates leaves a unit on a few pixels (3 of 6144 here).
    difference = np.abs(back.astype(int) - image).max(axis=2)
    assert difference.max() <= 1 and np.count_nonzero(difference) < 0.01 * difference.size


def test_16_bit_alpha_is_kept_and_colour_unpremultiplied_within_two_units(tmp_path):
    image = gradient16(alpha=True)
    write_image(tmp_path / "in.png", image)
    # A cage around the whole picture: every output pixel is the warp alone (no backdrop under it).
    xs, ys = np.linspace(-20, WIDTH + 20, 9), np.linspace(-20, HEIGHT + 20, 7)
    around = [[x, ys[0]] for x in xs] + [[xs[-1], y] for y in ys[1:]]
    around += [[x, ys[-1]] for x in xs[-2::-1]] + [[xs[0], y] for y in ys[-2:0:-1]]
    assert warp(tmp_path, "in.png", "out.png", cage=around) == 0
    back = read_photo(tmp_path / "out.png").pixels
    np.testing.assert_array_equal(back[..., 3], image[..., 3])
    # Premultiplied 16-bit colour keeps c * a / 65535 rounded, then divided back: for the alphas
    # here (>= 20000) that loses under a unit; the texture's filtering at texel centres adds one.
    error = np.abs(back[..., :3].astype(int) - image[..., :3]).max(axis=2)
    assert error.max() <= 2 and np.mean(error <= 1) > 0.99


def test_orientation_6_jpeg_warps_in_the_displayed_frame_with_profile_and_exif(tmp_path):
    raw = np.zeros((150, 200, 3), np.uint8)  # 200 wide as stored, 150 high
    raw[:, :100] = (200, 40, 40)
    profile = srgb_profile()
    (tmp_path / "phone.jpg").write_bytes(_jpeg_bytes(raw, exif=exif_with_orientation(6), icc_profile=profile))
    cage = [[20, 20], [130, 20], [130, 180], [20, 180]]  # inside 150 x 200, the displayed frame
    assert warp(tmp_path, "phone.jpg", "out.jpg", "--outside", "original", cage=cage) == 0
    result = Image.open(tmp_path / "out.jpg")
    assert result.size == (150, 200)
    assert result.info["icc_profile"] == profile
    assert result.getexif()[0x0112] == 1
    pixels = np.asarray(result)
    # Turned 90 degrees clockwise, the stored left half (red) is the displayed top half.
    assert pixels[20, 75, 0] > 150 and pixels[180, 75, 0] < 100
    assert warp(tmp_path, "phone.jpg", "out.png", "--outside", "original", cage=cage) == 0
    assert Image.open(tmp_path / "out.png").info["icc_profile"] == profile  # JPEG -> PNG


def test_png_to_png_keeps_the_icc_profile(tmp_path):
    profile = srgb_profile()
    write_image(tmp_path / "in.png", gradient16(), ImageMetadata(icc_profile=profile))
    assert warp(tmp_path, "in.png", "out.png") == 0
    assert read_photo(tmp_path / "out.png").metadata.icc_profile == profile


def test_transparent_to_jpeg_is_one_line_exit_2_and_background_fills(tmp_path, capfd):
    write_image(tmp_path / "in.png", (gradient16() >> 8).astype(np.uint8))
    capfd.readouterr()
    assert warp(tmp_path, "in.png", "out.jpg") == 2
    error = capfd.readouterr().err
    assert error.count("\n") == 1 and "--outside original or --background COLOR" in error
    assert not (tmp_path / "out.jpg").exists()
    assert warp(tmp_path, "in.png", "out.jpg", "--background", "#0000ff") == 0
    corner = np.asarray(Image.open(tmp_path / "out.jpg"))[1, 1]
    assert corner[2] > 240 and corner[:2].max() < 15


@pytest.mark.parametrize("compression", [5, 8])  # LZW, deflate
def test_16_bit_tiffs_compressed_either_way_are_read_at_16_bits(tmp_path, compression):
    image = gradient16()
    ok, data = cv2.imencode(
        ".tif", cv2.cvtColor(image, cv2.COLOR_RGBA2BGRA), [cv2.IMWRITE_TIFF_COMPRESSION, compression]
    )
    (tmp_path / "in.tif").write_bytes(data.tobytes())
    np.testing.assert_array_equal(read_photo(tmp_path / "in.tif").pixels, image)


def test_an_8_bit_tiff_with_alpha_is_read_straight_and_others_see_its_alpha(tmp_path):
    image = (gradient16(alpha=True) >> 8).astype(np.uint8)
    write_image(tmp_path / "out.tif", image)
    np.testing.assert_array_equal(read_photo(tmp_path / "out.tif").pixels, image)
    np.testing.assert_array_equal(np.asarray(Image.open(tmp_path / "out.tif")), image)  # ExtraSamples


def test_a_png_profile_over_pillows_1_mb_limit_is_carried_with_the_orientation(tmp_path):
    profile = bytearray(np.random.default_rng(4).integers(0, 256, 3 << 20, dtype=np.uint8).tobytes())
    profile[:4], profile[16:20], profile[36:40] = struct.pack(">I", len(profile)), b"RGB ", b"acsp"
    exif = exif_with_orientation(8).removeprefix(b"Exif\x00\x00")
    (tmp_path / "in.png").write_bytes(encode_image(gradient16(), "PNG", ImageMetadata(bytes(profile), exif)))
    photo = read_photo(tmp_path / "in.png")
    assert photo.metadata.icc_profile == bytes(profile)
    assert photo.pixels.shape == (WIDTH, HEIGHT, 4)  # orientation 8: turned a quarter


def test_animates_png_frames_keep_the_depth_and_the_profile(tmp_path):
    profile = srgb_profile()
    write_image(tmp_path / "in.png", gradient16(), ImageMetadata(icc_profile=profile))
    cage = {"control_points": CAGE}
    session = {
        "image": "in.png",
        "cage": cage,
        "target": cage,
        "kernel": "poisson",
        "view": {"scale": 1.0, "offset": [0, 0]},
        "outside": "original",
        "keyframes": [{"time": t, "target": cage} for t in (0.0, 1.0)],
    }
    (tmp_path / "session.json").write_text(json.dumps(session))
    frames = tmp_path / "frames"
    assert main(["animate", str(tmp_path / "session.json"), "--output", f"{frames}/", "--fps", "2"]) == 0
    for frame in sorted(frames.iterdir()):
        photo = read_photo(frame)
        assert photo.pixels.dtype == np.uint16 and photo.metadata.icc_profile == profile
        assert np.abs(photo.pixels.astype(int) - gradient16()).max() <= 1


@pytest.mark.parametrize("sixteen", [False, True])
def test_a_large_png_output_is_streamed_with_the_pixels_of_a_whole_one(tmp_path, monkeypatch, sixteen):
    image = gradient16() if sixteen else (gradient16() >> 8).astype(np.uint8)
    profile = srgb_profile()
    write_image(tmp_path / "in.png", image, ImageMetadata(icc_profile=profile))
    assert warp(tmp_path, "in.png", "whole.png", "--outside", "original") == 0
    # Every output counts as large: drawn in strips, compressed while drawn (app.io.images.tiles).
    monkeypatch.setattr("app.warp.pipeline.STREAMED_PIXELS", 0)
    monkeypatch.setattr("app.render.renderer.STRIP_ROWS", 16)
    assert warp(tmp_path, "in.png", "streamed.png", "--outside", "original") == 0
    whole, streamed = read_photo(tmp_path / "whole.png"), read_photo(tmp_path / "streamed.png")
    assert streamed.pixels.dtype == image.dtype and streamed.metadata.icc_profile == profile
    assert (tmp_path / "whole.png").read_bytes() != (tmp_path / "streamed.png").read_bytes()
    # Tiles off the warp's edges are drawn without multisampling: a unit where triangles meet.
    assert np.abs(streamed.pixels.astype(int) - whole.pixels).max() <= 1


def test_a_jpeg_packed_in_its_own_buffer_is_the_same_bytes_as_from_a_copy():
    image = np.random.default_rng(8).integers(0, 256, (700, 130, 4), dtype=np.uint8)  # over 256 rows
    image[..., 3] = 255
    kept = image.copy()
    assert encode_image(image, "JPEG") == encode_image(kept.copy(), "JPEG", consume=True)
    np.testing.assert_array_equal(image, kept)  # not consumed unless asked


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_opaque_is_every_alpha_at_its_maximum_read_whole_or_strided(dtype):
    maximum = np.iinfo(dtype).max
    image = np.random.default_rng(9).integers(0, maximum + 1, (40, 30, 4)).astype(dtype)
    image[..., 3] = maximum
    assert opaque(image) and opaque(image[:, ::2]) and opaque(image[:0])
    for row, column, alpha in ((0, 0, maximum - 1), (39, 29, 0), (17, 5, 1)):
        changed = image.copy()
        changed[row, column, 3] = alpha
        assert not opaque(changed) and not opaque(changed[:, ::-1])
    colours = image.copy()
    colours[..., :3] = maximum  # the colour at its maximum too: only the alpha counts
    assert opaque(colours)
    colours[3, 4, 3] = maximum - 1
    assert not opaque(colours)
