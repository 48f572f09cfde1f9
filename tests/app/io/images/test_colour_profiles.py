"""Profiles that match their pixels (issue 48 item 2): a CMYK JPEG converted to sRGB through its CMYK
profile (a profile made here: a lut8 from CMYK to Lab), a profile cut short or of another colour
space dropped with a note, the JPEG refusal naming --background."""

import io
import itertools
import json
import struct

import numpy as np
from PIL import Image, ImageCms

from app.__main__ import main
from app.io.files import image_metadata, read_photo, write_image
from app.io.images import ImageMetadata
from app.io.images.colour_profiles import cut_short, profile_space, srgb_profile

#: The CMYK of the test picture's four patches, and the sRGB the profile below gives each.
PATCHES = [(0, 0, 0, 0), (255, 0, 0, 0), (0, 0, 0, 255), (0, 255, 255, 0)]
CAGE = [[4, 4], [60, 4], [60, 28], [4, 28]]


def fixed(value: float) -> bytes:
    return struct.pack(">i", round(value * 65536))


def lut8(inputs: int, outputs: int, corner) -> bytes:
    """An ICC lut8Type of a 2-point grid: `corner` maps each corner (0/1 per input) to outputs in [0, 1]."""
    data = b"mft1" + bytes(4) + bytes((inputs, outputs, 2, 0))
    data += b"".join(fixed(v) for v in (1, 0, 0, 0, 1, 0, 0, 0, 1)) + bytes(range(256)) * inputs
    for point in itertools.product((0, 1), repeat=inputs):
        data += bytes(round(255 * min(max(v, 0.0), 1.0)) for v in corner(point))
    return data + bytes(range(256)) * outputs


def printed_rgb(c, m, y, k) -> tuple[float, float, float]:
    """The test profile's idea of an ink: a cyan that is (0, 0.65, 0.9), not OpenCV's naive (0, 1, 1)."""
    return ((1 - c) * (1 - k), (1 - 0.35 * c) * (1 - m) * (1 - k), (1 - 0.1 * c) * (1 - y) * (1 - k))


def lab_of(rgb) -> tuple[float, float, float]:
    """sRGB in [0, 1] as Pillow's LAB (the lut8 encoding), in [0, 1]."""
    transform = ImageCms.buildTransform(
        ImageCms.createProfile("sRGB"), ImageCms.createProfile("LAB"), "RGB", "LAB"
    )
    pixel = Image.new("RGB", (1, 1), tuple(round(255 * c) for c in rgb))
    return tuple(v / 255 for v in ImageCms.applyTransform(pixel, transform).getpixel((0, 0)))


def cmyk_profile() -> bytes:
    """An ICC v2 output profile of CMYK to Lab (A2B0) and back (B2A0, not used here)."""
    tags = [
        (b"A2B0", lut8(4, 3, lambda point: lab_of(printed_rgb(*point)))),
        (b"B2A0", lut8(3, 4, lambda point: (0, 0, 0, 0))),
        (b"desc", b"desc" + bytes(4) + struct.pack(">I", 5) + b"CMYK\0" + bytes(78)),
        (b"wtpt", b"XYZ " + bytes(4) + fixed(0.9642) + fixed(1.0) + fixed(0.8249)),
    ]
    start = 128 + 4 + 12 * len(tags)
    table, body = struct.pack(">I", len(tags)), b""
    for signature, data in tags:
        data += bytes(-len(data) % 4)
        table += signature + struct.pack(">II", start + len(body), len(data))
        body += data
    header = struct.pack(">I", start + len(body)) + b"lcms" + struct.pack(">I", 0x02100000)
    header += b"prtr" + b"CMYK" + b"Lab " + bytes(12) + b"acsp" + bytes(28)
    header += fixed(0.9642) + fixed(1.0) + fixed(0.8249)
    return header + bytes(128 - len(header)) + table + body


def cmyk_jpeg(path, profile: bytes | None) -> None:
    """A 64 x 32 CMYK JPEG of four patches (16 x 32 each), with `profile` embedded if given."""
    pixels = np.repeat(np.repeat(np.array(PATCHES, np.uint8)[None], 32, axis=0), 16, axis=1)
    options = {} if profile is None else {"icc_profile": profile}
    Image.fromarray(pixels, "CMYK").save(path, "JPEG", quality=100, **options)


def patch_colours(pixels: np.ndarray) -> np.ndarray:
    """The mean RGB of each patch's middle (4, 3)."""
    return np.array(
        [pixels[8:24, 16 * i + 4 : 16 * i + 12, :3].reshape(-1, 3).mean(axis=0) for i in range(4)]
    )


def test_the_test_profile_is_a_cmyk_profile_that_littlecms_reads():
    profile = cmyk_profile()
    assert profile_space(profile) == "CMYK" and cut_short(profile) is None
    assert ImageCms.getProfileDescription(ImageCms.ImageCmsProfile(io.BytesIO(profile))).strip() == "CMYK"


def test_a_cmyk_jpeg_is_converted_through_its_profile_and_carries_srgbs(tmp_path, capsys):
    cmyk_jpeg(tmp_path / "print.jpg", cmyk_profile())
    photo = read_photo(tmp_path / "print.jpg")
    expected = 255 * np.array([printed_rgb(*(np.array(p) / 255)) for p in PATCHES])
    # Through the profile's Lab grid of 2 points a side and back to sRGB: its interpolation bends
    # the cyan by 13 units of 255; OpenCV's CMYK decoding, without the profile, gives (1, 255, 255).
    assert np.abs(patch_colours(photo.pixels) - expected).max() <= 16
    assert photo.metadata.icc_profile == srgb_profile() and profile_space(srgb_profile()) == "RGB"
    assert any("converted to sRGB through its ICC profile" in line for line in photo.notes)
    assert image_metadata(tmp_path / "print.jpg").icc_profile == srgb_profile()  # the viewer's export
    (tmp_path / "cage.json").write_text(json.dumps({"control_points": CAGE}))
    for output in ("out.png", "out.jpg"):
        argv = ["warp", str(tmp_path / "print.jpg"), "--cage", str(tmp_path / "cage.json")]
        argv += [
            "--target",
            str(tmp_path / "cage.json"),
            "--outside",
            "original",
            "--output",
            str(tmp_path / output),
        ]
        assert main(argv) == 0
        written = Image.open(tmp_path / output)
        assert written.mode.startswith("RGB") and written.info["icc_profile"] == srgb_profile()


def test_a_cmyk_jpeg_without_a_profile_is_made_rgb_and_carries_none(tmp_path):
    cmyk_jpeg(tmp_path / "print.jpg", None)
    photo = read_photo(tmp_path / "print.jpg")
    assert photo.metadata.icc_profile is None and photo.notes == ()
    assert photo.pixels[16, 4, :3].tolist() == [255, 255, 255]


def test_a_cmyk_profile_littlecms_cannot_read_is_dropped_with_a_note(tmp_path):
    profile = bytearray(cmyk_profile())
    start = profile.index(b"mft1")
    profile[start : start + 4] = b"mft9"  # the CMYK-to-Lab table of a type that does not exist
    cmyk_jpeg(tmp_path / "print.jpg", bytes(profile))
    photo = read_photo(tmp_path / "print.jpg")
    assert photo.metadata.icc_profile is None
    assert [line for line in photo.notes if line.startswith("its CMYK ICC profile cannot be used")]
    assert image_metadata(tmp_path / "print.jpg").icc_profile is None


def test_a_profile_cut_short_is_named_and_dropped(tmp_path):
    profile = srgb_profile()
    write_image(
        tmp_path / "in.png", np.full((8, 8, 4), 200, np.uint8), ImageMetadata(icc_profile=profile[:300])
    )
    photo = read_photo(tmp_path / "in.png")
    assert photo.metadata.icc_profile is None
    assert photo.notes == (
        f"its ICC profile is cut short (300 of the {len(profile)} bytes it declares); dropped",
    )


def test_a_grey_profile_is_dropped_from_the_rgb_pixels_with_a_note(tmp_path):
    grey = bytearray(srgb_profile())
    grey[16:20] = b"GRAY"
    write_image(
        tmp_path / "in.png", np.full((8, 8, 4), 200, np.uint8), ImageMetadata(icc_profile=bytes(grey))
    )
    photo = read_photo(tmp_path / "in.png")
    assert photo.metadata.icc_profile is None
    assert photo.notes == ("its ICC profile describes GRAY pixels, not the RGB ones written; dropped",)


def test_the_jpeg_refusal_of_transparent_pixels_names_background(tmp_path, capfd):
    image = np.full((32, 64, 4), 200, np.uint8)
    image[..., 3] = 100
    write_image(tmp_path / "in.png", image)
    (tmp_path / "cage.json").write_text(json.dumps({"control_points": CAGE}))
    argv = ["warp", str(tmp_path / "in.png"), "--cage", str(tmp_path / "cage.json")]
    argv += [
        "--target",
        str(tmp_path / "cage.json"),
        "--outside",
        "original",
        "--output",
        str(tmp_path / "out.jpg"),
    ]
    assert main(argv) == 2
    assert "give --background COLOR" in capfd.readouterr().err
    assert not (tmp_path / "out.jpg").exists()
    assert main([*argv, "--background", "white"]) == 0
