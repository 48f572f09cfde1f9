"""Tests of app.io.files: validation messages, image decoding, atomic writes."""

import json
import os

import cv2
import numpy as np
import pytest
from support.png_files import declared_png

from app.io import files
from app.io.files import (
    InputError,
    cage_curve,
    check_writable,
    read_cage,
    read_image,
    read_json,
    write_atomic,
    write_cage,
    write_png,
)

SQUARE = [[10, 10], [50, 10], [50, 40], [10, 40]]


def write(path, text):
    path.write_text(text)
    return path


# -- JSON and cages ----------------------------------------------------------------------


def test_read_cage_round_trip(tmp_path):
    write_cage(tmp_path / "cage.json", np.array(SQUARE, dtype=float) + 0.12345)
    points = read_cage(tmp_path / "cage.json")
    assert points.shape == (4, 2) and points.dtype == np.float64
    assert np.allclose(points, np.array(SQUARE) + 0.123)


@pytest.mark.parametrize(
    "text, message",
    [
        ("{not json", r"cage.json: not valid JSON \(.* line 1, column 2\)"),
        ("[1, 2]", r"cage.json: expected an object with \"control_points\", got a list"),
        ('{"points": []}', r'cage.json: missing "control_points"'),
        ('{"control_points": "abc"}', r"must be a list of \[x, y\] pairs, got a string"),
        ('{"control_points": [[1, 2], [3, "4"], [5, 6]]}', r"control_points\[1\] must be a pair of numbers"),
        ('{"control_points": [[1, 2], [3, true], [5, 6]]}', r"control_points\[1\] must be a pair of numbers"),
        ('{"control_points": [[1, 2], [3, 4, 5], [5, 6]]}', r"control_points\[1\] must be a pair"),
        ('{"control_points": [[1, 2], [3, 4]]}', r"cage.json: control_points needs at least 3 points, got 2"),
        ('{"control_points": [[1, 2], [3, NaN], [5, 6]]}', r"cage.json: .*NaN or infinite .*index 1"),
        ('{"control_points": [[1, 2], [3, Infinity], [5, 6]]}', r"NaN or infinite"),
    ],
)
def test_bad_cages_name_the_file_and_the_problem(tmp_path, text, message):
    with pytest.raises(InputError, match=message):
        read_cage(write(tmp_path / "cage.json", text))


def test_missing_empty_and_directory_json(tmp_path):
    with pytest.raises(InputError, match=r"nope.json: no such file"):
        read_json(tmp_path / "nope.json")
    with pytest.raises(InputError, match=r"empty.json: the file is empty"):
        read_json(write(tmp_path / "empty.json", ""))
    with pytest.raises(InputError, match=r"is a directory"):
        read_json(tmp_path)


def test_cage_curve_passes_on_self_intersection():
    bow_tie = np.array([[0, 0], [10, 10], [10, 0], [0, 10]], dtype=float)
    with pytest.raises(InputError, match=r"^bow.json: the curve crosses or touches itself"):
        cage_curve(bow_tie, "bow.json")
    assert cage_curve(np.array(SQUARE, dtype=float), "square.json").n == 4


# -- sessions -----------------------------------------------------------------------------


# -- images ---------------------------------------------------------------------------------


def encoded(image, extension=".png"):
    ok, data = cv2.imencode(extension, image)
    assert ok
    return data.tobytes()


def test_read_image_converts_every_layout_to_rgba(tmp_path):
    bgr = np.zeros((5, 7, 3), dtype=np.uint8)
    bgr[..., 0] = 200  # blue in OpenCV's order
    (tmp_path / "bgr.png").write_bytes(encoded(bgr))
    rgba = read_image(tmp_path / "bgr.png")
    assert rgba.shape == (5, 7, 4) and rgba.dtype == np.uint8
    assert rgba[0, 0].tolist() == [0, 0, 200, 255]

    bgra = np.zeros((5, 7, 4), dtype=np.uint8)
    bgra[..., 2], bgra[..., 3] = 100, 30
    (tmp_path / "bgra.png").write_bytes(encoded(bgra))
    assert read_image(tmp_path / "bgra.png")[0, 0].tolist() == [100, 0, 0, 30]

    grey16 = np.full((4, 4), 65535, dtype=np.uint16)
    (tmp_path / "grey16.png").write_bytes(encoded(grey16))
    grey16 = read_image(tmp_path / "grey16.png")  # the depth is kept (issue 36)
    assert grey16.dtype == np.uint16 and grey16[0, 0].tolist() == [65535] * 4


def test_bad_images(tmp_path, capfd):
    data = encoded(np.zeros((40, 40, 3), dtype=np.uint8))
    (tmp_path / "truncated.png").write_bytes(data[: len(data) // 2])
    (tmp_path / "garbage.png").write_bytes(b"this is not an image at all")
    (tmp_path / "empty.png").write_bytes(b"")
    capfd.readouterr()
    with pytest.raises(InputError, match=r"truncated.png: cannot decode the image \(the file is cut short\)"):
        read_image(tmp_path / "truncated.png")
    jpeg = cv2.imencode(".jpg", np.zeros((40, 40, 3), dtype=np.uint8))[1].tobytes()
    (tmp_path / "truncated.jpg").write_bytes(jpeg[: len(jpeg) // 3])
    with pytest.raises(InputError, match=r"truncated.jpg: cannot decode the image \(the file is cut short\)"):
        read_image(tmp_path / "truncated.jpg")
    with pytest.raises(InputError, match=r"garbage.png: cannot decode the image"):
        read_image(tmp_path / "garbage.png")
    with pytest.raises(InputError, match=r"empty.png: the file is empty"):
        read_image(tmp_path / "empty.png")
    with pytest.raises(InputError, match=r"missing.png: no such file"):
        read_image(tmp_path / "missing.png")
    # The decoders' own complaints are captured, not printed.
    assert capfd.readouterr().err == ""


# -- writing ------------------------------------------------------------------------------------


def test_write_png_round_trip(tmp_path):
    image = np.random.default_rng(0).integers(0, 256, (6, 9, 4), dtype=np.uint8)
    write_png(tmp_path / "out.png", image)
    assert np.array_equal(read_image(tmp_path / "out.png"), image)
    assert [p.name for p in tmp_path.iterdir()] == ["out.png"], "no temporary file may remain"


def test_atomic_write_keeps_mode_and_leaves_old_file_on_failure(tmp_path, monkeypatch):
    path = tmp_path / "data.bin"
    path.write_bytes(b"old")
    os.chmod(path, 0o640)
    write_atomic(path, b"new")
    assert path.read_bytes() == b"new" and (path.stat().st_mode & 0o777) == 0o640

    def disk_full(descriptor):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "fsync", disk_full)
    with pytest.raises(InputError, match=r"data.bin: cannot write \(No space left on device\)"):
        write_atomic(path, b"partial")
    assert path.read_bytes() == b"new"
    assert [p.name for p in tmp_path.iterdir()] == ["data.bin"]


def test_check_writable(tmp_path):
    check_writable(tmp_path / "new.png", suffix=".png")
    with pytest.raises(InputError, match=r"must end in .png"):
        check_writable(tmp_path / "out.jpg", suffix=".png")
    with pytest.raises(InputError, match=r"directory .*nowhere does not exist"):
        check_writable(tmp_path / "nowhere" / "out.png")
    with pytest.raises(InputError, match=r"it is a directory"):
        check_writable(tmp_path)


def test_a_byte_order_mark_is_not_part_of_the_json(tmp_path):
    path = tmp_path / "bom.json"
    path.write_bytes(b"\xef\xbb\xbf" + json.dumps({"control_points": [[0, 0], [4, 0], [0, 3]]}).encode())
    assert read_cage(path).tolist() == [[0, 0], [4, 0], [0, 3]]


def test_images_are_refused_by_their_header_before_decoding(tmp_path, monkeypatch):
    decoded = []
    monkeypatch.setattr(files.cv2, "imdecode", lambda *arguments: decoded.append(1))
    (tmp_path / "huge.png").write_bytes(declared_png(30000, 30000))
    with pytest.raises(
        InputError, match=r"^\S+huge.png: the PNG image is 30000x30000 pixels \(900 megapixels\)"
    ):
        read_image(tmp_path / "huge.png")
    limit = files.MAX_IMAGE_PIXELS
    (tmp_path / "edge.png").write_bytes(declared_png(limit // 2, 2))
    with pytest.raises(InputError, match=r"cannot decode the image"):  # allowed: the decoder is asked
        read_image(tmp_path / "edge.png")
    assert decoded == [1]


def test_image_files_too_large_to_read_are_refused(tmp_path, monkeypatch):
    monkeypatch.setattr(files, "MAX_IMAGE_FILE_BYTES", 2**20)
    (tmp_path / "big.bmp").write_bytes(bytes(2 * 2**20))
    with pytest.raises(InputError, match=r"big.bmp: the file is 2 MiB; at most 1 MiB can be read"):
        read_image(tmp_path / "big.bmp")


# -- file kinds, sizes, names, numbers (issue 23) -------------------------------------------


@pytest.mark.parametrize("reader", [read_cage, read_image, read_json], ids=["cage", "image", "json"])
def test_files_that_are_not_regular_are_refused_without_reading(tmp_path, reader):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)  # reading it would block forever: nobody writes
    with pytest.raises(InputError, match=r"pipe: is a FIFO \(named pipe\), not a regular file$"):
        reader(fifo)
    with pytest.raises(InputError, match=r"^/dev/zero: is a character device, not a regular file$"):
        reader("/dev/zero")  # endless
    with pytest.raises(InputError, match=r"is a directory, not a file$"):
        reader(tmp_path)


def test_json_files_are_limited_while_reading(tmp_path, monkeypatch):
    monkeypatch.setattr(files, "MAX_JSON_FILE_BYTES", 2**20)
    big = write(tmp_path / "big.json", json.dumps({"control_points": SQUARE * 40_000}))
    with pytest.raises(InputError, match=r"big.json: the file is 2 MiB; at most 1 MiB can be read"):
        read_cage(big)
    # A file whose size the system does not know (0 in /proc) is cut off after the limit.
    monkeypatch.setattr(files, "MAX_JSON_FILE_BYTES", 64)
    with pytest.raises(InputError, match=r"status: the file is 0 MiB or more; at most 0 MiB"):
        read_json("/proc/self/status")


@pytest.mark.parametrize(
    "value, expected",
    [(3, 3.0), (-2.5, -2.5), (10**400, None), (-(10**400), None), (float("nan"), None), (True, None)],
)
def test_finite_number_takes_json_numbers_that_floats_hold(value, expected):
    assert files.finite_number(value) == expected


def test_output_names_longer_than_255_bytes_are_refused_before_any_work(tmp_path):
    with pytest.raises(InputError, match=r"the file name is 304 bytes long; at most 255 are allowed$"):
        check_writable(tmp_path / ("a" * 300 + ".png"), suffix=".png")
    with pytest.raises(InputError, match=r": cannot write \(File name too long\)$"):
        check_writable(tmp_path / ("a" * 300) / "x.png", suffix=".png")
    check_writable(tmp_path / ("a" * 251 + ".png"), suffix=".png")  # 255 bytes: allowed
    write_png(tmp_path / ("a" * 251 + ".png"), np.zeros((2, 2, 4), np.uint8))
