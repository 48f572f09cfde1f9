"""Tests of the command line (app.commands.cli, app.__main__, app.studies.compare's command, the help texts).

Bad input must give exit code 2 and exactly one line on stderr naming the problem
and the file, no traceback, no output file, and an existing output untouched.
Most cases run `main(argv)` in-process (capfd also catches what C libraries print);
a few run ``python -m app`` in a subprocess end to end.
"""

import argparse
import json
import re
import resource
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from support.commands import (  # noqa: F401 (fixtures: files, private_cache)
    AFFINE,
    CAGE,
    HEIGHT,
    WIDTH,
    files,
    picture,
    private_cache,
    run_main,
    transformed,
    warp_argv,
)
from support.paths import ROOT
from support.png_files import blank_png, declared_png

from app.__main__ import main
from app.commands.cli import build_parser, program_name
from app.io.files import kernel_names, read_cage, read_image, write_png
from app.viewer.demos import SCRIPT_FORMAT

FIGURE_EIGHT = [[103, 74], [135, 74], [135, 46], [103, 46], [57, 74], [25, 74], [25, 46], [57, 46]]
L_AROUND_CORNER = [[-40, -40], [10, -40], [60, -40], [60, -12], [-12, -12], [-12, 60], [-40, 60], [-40, 10]]
CAGE_TEXT = json.dumps({"control_points": CAGE})


# Each case: a function (directory) -> argv that writes the bad input, and the
# pattern the single stderr line must match.
def _write(d, name, content):
    path = d / name
    path.write_bytes(content) if isinstance(content, bytes) else path.write_text(content)
    return path


def _cage(d, name, points):
    return _write(d, name, json.dumps({"control_points": points}))


BAD_WARP_INPUTS = {
    "missing image": (lambda d: warp_argv(d, image=d / "nope.png"), r"nope.png: no such file"),
    "corrupt image": (
        lambda d: warp_argv(d, image=_write(d, "bad.png", (d / "picture.png").read_bytes()[:300])),
        r"bad.png: cannot decode the image",
    ),
    "not an image": (
        lambda d: warp_argv(d, image=_write(d, "text.png", "hello")),
        r"text.png: cannot decode the image",
    ),
    "malformed JSON": (
        lambda d: warp_argv(d, **{"--cage": _write(d, "c.json", '{"control_points": [[1, 2],')}),
        r"c.json: not valid JSON \(.*line 1",
    ),
    "wrongly typed JSON": (
        lambda d: warp_argv(d, **{"--cage": _cage(d, "c.json", [["a", 1], [2, 3], [4, 5]])}),
        r"c.json: control_points\[0\] must be a pair of numbers",
    ),
    "JSON not an object": (
        lambda d: warp_argv(d, **{"--target": _write(d, "t.json", "[]")}),
        r"t.json: expected an object with \"control_points\", got a list",
    ),
    "two control points": (
        lambda d: warp_argv(d, **{"--cage": _cage(d, "c.json", CAGE[:2])}),
        r"c.json: control_points needs at least 3 points, got 2",
    ),
    "self-intersecting cage": (
        lambda d: warp_argv(d, **{"--cage": _cage(d, "c.json", FIGURE_EIGHT)}),
        r"c.json: the curve crosses or touches itself near control points",
    ),
    "target count differs": (
        lambda d: warp_argv(d, **{"--target": _cage(d, "t.json", CAGE[:-1])}),
        r"t.json: has 7 control points but .*cage.json has 8",
    ),
    "NaN in target": (
        lambda d: warp_argv(
            d,
            **{"--target": _write(d, "t.json", json.dumps({"control_points": CAGE}).replace("30", "NaN", 1))},
        ),
        r"t.json: control_points has 1 point\(s\) with NaN",
    ),
    "cage off the image": (
        lambda d: warp_argv(d, **{"--cage": _cage(d, "c.json", (np.array(CAGE) + [500, 0]).tolist())}),
        r"c.json: the cage lies entirely outside the 160x120 image",
    ),
    "cage around the image corner": (
        # The bounding box overlaps the image, the domain covers no pixel centre.
        lambda d: warp_argv(d, **{"--cage": _cage(d, "c.json", L_AROUND_CORNER)}),
        r"c.json: the cage lies entirely outside",
    ),
    "absurd coordinates": (
        lambda d: warp_argv(d, **{"--cage": _cage(d, "c.json", (np.array(CAGE) * 1e9).tolist())}),
        r"c.json: control points lie over 10\^7 pixels away",
    ),
    "unknown kernel": (
        lambda d: warp_argv(d, **{"--kernel": "bogus"}),
        r"unknown kernel 'bogus'; choose one of .*harmonic-like",
    ),
    "output directory missing": (
        lambda d: warp_argv(d, **{"--output": d / "missing" / "out.png"}),
        r"out.png: cannot write, directory .*missing does not exist",
    ),
    "output is a directory": (
        lambda d: warp_argv(d, **{"--output": (d / "folder.png").mkdir() or d / "folder.png"}),
        r"folder.png: cannot write, it is a directory",
    ),
    "output not an image format": (
        lambda d: warp_argv(d, **{"--output": d / "out.bmp"}),
        r"out.bmp: the output file name must end in .png, .tif, .tiff, .jpg, .jpeg, .webp",
    ),
    "transparent JPEG": (
        lambda d: warp_argv(d, **{"--output": d / "out.jpg"}),
        r"out.jpg: JPEG has no transparency .* give --outside original or --background COLOR",
    ),
    "missing --cage": (lambda d: warp_argv(d, **{"--cage": None}), r"warp needs --cage \(or --session\)"),
    "nothing": (
        lambda d: ["warp"],
        r"warp needs IMAGE, --cage, --target or --pins \(or --session\) and --output, e\.g\. "
        r"warp photo\.png .*python -m app demo --list",
    ),
    "session and image": (
        lambda d: warp_argv(d, **{"--session": d / "session.json", "--cage": None, "--target": None}),
        r"give either --session or IMAGE .*not both",
    ),
    "session without target": (
        lambda d: [
            "warp",
            "--output",
            d / "out.png",
            "--session",
            _write(
                d,
                "s.json",
                json.dumps(
                    {k: v for k, v in json.loads((d / "session.json").read_text()).items() if k != "target"}
                ),
            ),
        ],
        r"s.json: missing key\(s\) target",
    ),
    "session image missing": (
        lambda d: [
            "warp",
            "--output",
            d / "out.png",
            "--session",
            _write(d, "s.json", (d / "session.json").read_text().replace("picture.png", "gone.png")),
        ],
        r"s.json: its \"image\" 'gone.png' is .*gone.png, which does not exist \(a relative \"image\"",
    ),
    # -- the fuzz run of issue 13: each of these ended in a traceback, a silent default or worse
    "image declaring 30000x30000": (
        lambda d: warp_argv(d, image=_write(d, "huge.png", declared_png(30000, 30000))),
        r"huge.png: the PNG image is 30000x30000 pixels \(900 megapixels\); at most 134 megapixels",
    ),
    "integer 10^400 in a cage": (
        lambda d: warp_argv(
            d, **{"--cage": _write(d, "c.json", CAGE_TEXT.replace("30", "1" + "0" * 400, 1))}
        ),
        r"c.json: control_points\[0\] = \[1000.*\.\.\. is out of range: coordinates must lie within "
        r"\+-1e\+15",
    ),
    "a point at 1e308": (
        lambda d: warp_argv(d, **{"--cage": _write(d, "c.json", CAGE_TEXT.replace("30", "1e308", 1))}),
        r"c.json: control_points\[0\] = \[1e\+308, 20\] is out of range",
    ),
    "an integer of 5000 digits": (
        lambda d: warp_argv(d, **{"--cage": _write(d, "c.json", CAGE_TEXT.replace("30", "7" * 5000, 1))}),
        r"c.json: cannot read the JSON \(Exceeds the limit \(4300 digits\)",
    ),
    "JSON nested 100,000 deep": (
        lambda d: warp_argv(d, **{"--cage": _write(d, "c.json", "[" * 100_000 + "]" * 100_000)}),
        r"c.json: cannot read the JSON \(arrays or objects nested too deeply\)",
    ),
    "--max-edge 1e300": (
        lambda d: [*warp_argv(d), "--max-edge", "1e300"],
        r"cage.json: meshing: max_edge=1e\+300 is longer than the domain; use 0 < max_edge <= 1\d\d\.\d+",
    ),
    "--samples-per-segment 10^9": (
        lambda d: [*warp_argv(d), "--samples-per-segment", "1000000000"],
        r"--samples-per-segment: samples_per_segment=1000000000 gives 8,000,000,000 boundary samples "
        r"for 8 control points, more than the 1,048,576 allowed; use 2 <= samples_per_segment <= 131072",
    ),
    "empty --kernel": (lambda d: warp_argv(d, **{"--kernel": ""}), r"unknown kernel ''; choose one of"),
    "--output is the input image": (
        lambda d: warp_argv(d, **{"--output": d / "picture.png"}),
        r"picture.png: is the input image; give another --output, or --overwrite-input to replace it",
    ),
    "bad --size": (lambda d: [*warp_argv(d), "--size", "12by4"], r"--size: expected WIDTHxHEIGHT"),
    "negative --scale": (lambda d: [*warp_argv(d), "--scale", "-2"], r"--scale: must be a finite number > 0"),
    "missing --output": (lambda d: warp_argv(d, **{"--output": None}), r"warp needs --output, e\.g\. "),
}


@pytest.mark.parametrize("case", list(BAD_WARP_INPUTS))
@pytest.mark.parametrize("existing_output", [False, True], ids=["no-output", "existing-output"])
def test_bad_warp_input(files, capfd, case, existing_output):
    make_argv, pattern = BAD_WARP_INPUTS[case]
    argv = make_argv(files)
    output = files / "out.png"
    if existing_output:
        output.write_bytes(b"previous result")
    code, out, err = run_main(argv, capfd)
    assert_one_line_error(code, err, pattern)
    if existing_output:
        assert output.read_bytes() == b"previous result"
    else:
        assert not output.exists()
    assert not list(files.glob(".out.png.*")), "no temporary file may remain"


def assert_one_line_error(code, err, pattern, expected_code=2):
    lines = err.strip().splitlines()
    assert len(lines) == 1, f"expected one line on stderr, got:\n{err}"
    assert "Traceback" not in err
    assert re.search(pattern, lines[0]), lines[0]
    assert code == expected_code


# -- other commands ----------------------------------------------------------------------


def test_no_arguments_open_the_viewer_and_bench_dispatches_to_app_bench(monkeypatch):
    calls, opened = [], []
    monkeypatch.setattr("app.bench.table.run_bench", lambda args: calls.append(args) or 0)
    monkeypatch.setattr("app.viewer.window.run", lambda document, options: opened.append(document) or 0)
    assert main([]) == 0
    assert main(["bench", "--quick"]) == 0
    assert [(args.quick, args.repeats) for args in calls] == [(True, 3)]
    assert [document.snapshot.image.name for document in opened] == ["starfish.png"]


def test_options_without_a_command_are_the_viewers(monkeypatch, tmp_path):
    opened = []
    monkeypatch.setattr("app.viewer.window.run", lambda document, options: opened.append(options) or 0)
    monkeypatch.setenv("TRANSFINITE_STATE_DIR", str(tmp_path))
    assert main(["--stats", "--max-edge", "20"]) == 0
    assert main(["--vertices", "90000"]) == 0
    assert [(options.stats, options.max_edge, options.vertices) for options in opened] == [
        (True, 20.0, None),
        (False, None, 90000),
    ]


@pytest.mark.parametrize(
    "argv, message",
    [
        (["demo", "nosuch"], r"unknown demo 'nosuch'; choose one of starfish, character, pattern"),
        (["view", "--cage", "cage.json"], r"--cage needs an IMAGE"),
        (["view", "missing.png"], r"missing.png: no such file"),
        (["demo", "--max-edge", "2", "--vertices", "9000"], r"--max-edge and --vertices both set the mesh"),
        (["view", "--vertices", "0"], r"--vertices: .*"),
    ],
)
def test_viewer_commands_report_bad_input(capfd, monkeypatch, tmp_path, argv, message):
    monkeypatch.chdir(tmp_path)
    code, out, err = run_main(argv, capfd)
    assert_one_line_error(code, err, message)


def test_unknown_command(capfd):
    code, out, err = run_main(["morph"], capfd)
    assert_one_line_error(code, err, r"invalid choice: 'morph'")


def test_bad_input_end_to_end_in_a_subprocess(files):
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "app",
            *map(str, warp_argv(files, **{"--cage": _cage(files, "c.json", CAGE[:2])})),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert_one_line_error(result.returncode, result.stderr, r"c.json: control_points needs at least 3 points")
    assert result.stdout == ""
    assert not (files / "out.png").exists()


def test_a_warp_loads_no_module_it_does_not_use(files, private_cache):
    # Its start-up (issue 48): `core` imports each name's module at its first use, so a plain warp
    # loads neither the injectivity proofs, the pins, nor the finite-element basis (scipy.sparse).
    unused = ("core.injectivity", "core.pins", "core.meshes.harmonic")
    code = (
        "import sys; from app.__main__ import main; "
        f"code = main({[str(a) for a in warp_argv(files)]!r}); "
        f"print(code, sorted(m for m in sys.modules if m.startswith({unused!r})))"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300
    )
    assert result.stdout.strip().splitlines()[-1] == "0 []", result.stderr
    assert (files / "out.png").exists()


GIB = 1 << 30


@pytest.fixture(scope="module")
def big_images(tmp_path_factory):
    """A PNG declaring 30000x30000 pixels without data, a real blank one of that size (900
    megapixels, 1 MB), and a real blank RGB one of 11000x11000 (below the limit, 363 MB decoded)."""
    directory = tmp_path_factory.mktemp("big")
    (directory / "declared.png").write_bytes(declared_png(30000, 30000))
    (directory / "blank.png").write_bytes(blank_png(30000, 30000))
    (directory / "large.png").write_bytes(blank_png(11000, 11000, channels=3))
    return directory


def run_limited(argv, address_space):
    """``python -m app ARGV`` with its address space limited like ``prlimit --as``."""
    limit = (int(address_space), int(address_space))
    return subprocess.run(
        [sys.executable, "-m", "app", *map(str, argv)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_AS, limit),
    )


@pytest.mark.parametrize(
    ("command", "pattern"),
    [
        (
            lambda d, big: warp_argv(d, image=big / "declared.png"),
            r"declared.png: the PNG image is 30000x30000",
        ),
        (lambda d, big: warp_argv(d, image=big / "blank.png"), r"blank.png: the PNG image is 30000x30000"),
        (
            lambda d, big: ["fit", big / "blank.png", "--output", d / "fitted.json"],
            r"blank.png: the PNG image is",
        ),
        (lambda d, big: [*warp_argv(d), "--samples-per-segment", "1000000000"], r"at most|allowed; use 2 <="),
        (
            lambda d, big: [*warp_argv(d), "--max-edge", "1e300"],
            r"max_edge=1e\+300 is longer than the domain",
        ),
        (
            lambda d, big: warp_argv(d, **{"--cage": _write(d, "c.json", "[" * 100_000 + "]" * 100_000)}),
            r"nested too deeply",
        ),
    ],
    ids=["declared", "blank", "fit-blank", "samples", "max-edge", "deep-json"],
)
def test_bad_input_under_a_4_gib_address_space_is_one_line(files, big_images, command, pattern):
    result = run_limited(command(files, big_images), 4 * GIB)
    assert_one_line_error(result.returncode, result.stderr, pattern)
    assert not (files / "out.png").exists() and not (files / "fitted.json").exists()


def test_an_allocation_failure_is_one_line_and_exit_1(files, big_images):
    # 121 megapixels is a valid input; 1.3 GiB of address space cannot hold it decoded.
    result = run_limited(["fit", big_images / "large.png", "--output", files / "c.json"], 1.3 * GIB)
    assert_one_line_error(result.returncode, result.stderr, r"^error: out of memory: ", expected_code=1)
    assert not (files / "c.json").exists()


@pytest.mark.parametrize(
    "error",
    [MemoryError("Unable to allocate 2.51 GiB for an array with shape (30000, 30000, 3)"), "opencv"],
)
def test_allocation_failures_anywhere_map_to_exit_1(files, capfd, monkeypatch, error):
    if error == "opencv":
        error = cv2.error("OpenCV(5.0.0) alloc.cpp:73: error: (-4:Insufficient memory)")
        error.code, error.err = cv2.Error.StsNoMem, "Failed to allocate 2700000000 bytes"

    def fail(*arguments, **keywords):
        raise error

    monkeypatch.setattr("core.triangulate", fail)
    code, _, err = run_main(warp_argv(files), capfd)
    assert_one_line_error(
        code, err, r"^error: out of memory: (Unable to allocate 2.51 GiB|Failed to allocate)", 1
    )
    assert not (files / "out.png").exists()


def mutated(data: bytes, seed: int) -> bytes:
    """`data` with a few random bytes replaced, inserted or deleted (fixed seed)."""
    rng = np.random.default_rng(seed)
    data = bytearray(data)
    for _ in range(int(rng.integers(1, 4))):
        at = int(rng.integers(len(data)))
        kind = rng.integers(3)
        if kind == 0:
            data[at] = int(rng.integers(256))
        elif kind == 1:
            data[at:at] = rng.bytes(int(rng.integers(1, 4)))
        else:
            del data[at : at + int(rng.integers(1, 4))]
    return bytes(data)


@pytest.mark.parametrize("seed", range(12))
def test_fuzzed_inputs_work_or_fail_in_one_line(files, capfd, seed):
    # A mutated image, cage, target or session: exit 0 with an output, or exit 2 with one line,
    # no output file and never a traceback.
    name = ("picture.png", "cage.json", "target.json", "session.json")[seed % 4]
    path = files / name
    path.write_bytes(mutated(path.read_bytes(), seed))
    if name == "session.json":
        argv = ["warp", "--session", path, "--output", files / "out.png"]
    else:
        argv = warp_argv(files)
    code, _, err = run_main(argv, capfd)
    assert "Traceback" not in err
    if code == 0:
        assert read_image(files / "out.png").shape == (HEIGHT, WIDTH, 4)
    else:
        assert_one_line_error(code, err, r"^error: ")
        assert not (files / "out.png").exists()


def ellipse_picture():
    image = np.zeros((HEIGHT, WIDTH, 4), dtype=np.uint8)
    cv2.ellipse(image, (80, 60), (50, 35), 0, 0, 360, (200, 40, 40, 255), -1, cv2.LINE_AA)
    return image


def test_fit_writes_a_cage(tmp_path, capfd):
    write_png(tmp_path / "blob.png", ellipse_picture())
    code, out, err = run_main(
        ["fit", tmp_path / "blob.png", "--output", tmp_path / "cage.json", "--points", 10], capfd
    )
    assert code == 0, err
    points = read_cage(tmp_path / "cage.json")
    assert points.shape == (10, 2)
    assert np.allclose(points.mean(axis=0), (80.5, 60.5), atol=1.0)


def test_fit_writes_an_svg_cage_that_warp_reads(tmp_path, capfd):
    write_png(tmp_path / "blob.png", ellipse_picture())
    code, out, err = run_main(
        ["fit", tmp_path / "blob.png", "--output", tmp_path / "cage.svg", "--points", 10], capfd
    )
    assert code == 0, err
    text = (tmp_path / "cage.svg").read_text()
    assert f'width="{WIDTH}" height="{HEIGHT}"' in text and " T " in text
    points = read_cage(tmp_path / "cage.svg")
    assert points.shape == (10, 2)
    assert np.allclose(points.mean(axis=0), (80.5, 60.5), atol=1.0)
    argv = ["warp", tmp_path / "blob.png", "--cage", tmp_path / "cage.svg", "--target", tmp_path / "cage.svg"]
    code, out, err = run_main([*argv, "--output", tmp_path / "out.png"], capfd)
    assert code == 0, err
    assert read_image(tmp_path / "out.png").shape == (HEIGHT, WIDTH, 4)


def test_warp_refuses_an_svg_without_a_closed_path(files, capfd):
    (files / "open.svg").write_text('<svg xmlns="http://www.w3.org/2000/svg"><path d="M 0 0 L 9 9"/></svg>')
    code, out, err = run_main(warp_argv(files, **{"--cage": files / "open.svg"}), capfd)
    assert_one_line_error(code, err, r"open.svg: no closed path in the SVG")
    assert not (files / "out.png").exists()


@pytest.mark.parametrize(
    "argv, pattern",
    [
        (["fit", "{d}/empty.png", "--output", "{d}/cage.json"], r"empty.png: found no object in the image"),
        (
            ["fit", "{d}/blob.png", "--output", "{d}/cage.txt"],
            r"cage.txt: the output file name must end in .json, .svg",
        ),
        (
            ["fit", "{d}/blob.png", "--output", "{d}/cage.json", "--points", "2"],
            r"--points 2: a closed cage needs at least 3 control points",
        ),
        (
            ["fit", "{d}/blob.png", "--output", "{d}/cage.json", "--points", "x"],
            r"--points: expected an integer, got 'x'",
        ),
    ],
)
def test_fit_bad_input(tmp_path, capfd, argv, pattern):
    write_png(tmp_path / "blob.png", ellipse_picture())
    write_png(tmp_path / "empty.png", np.zeros((40, 40, 4), dtype=np.uint8))
    code, out, err = run_main([a.format(d=tmp_path) for a in argv], capfd)
    assert_one_line_error(code, err, pattern)
    assert not (tmp_path / "cage.json").exists() and not (tmp_path / "cage.txt").exists()


@pytest.mark.parametrize(
    "data, pattern",
    [
        ({"values": [0.5] * 5}, r"v.json: has 5 values but the cage has 8 control points"),
        ({"values": ["a"] * 8}, r'v.json: expected \{"values": \[F_1, ..., F_n\]\} with n numbers'),
        ([0.5] * 8, r'v.json: expected \{"values"'),
    ],
)
def test_compare_bad_data(files, capfd, data, pattern):
    (files / "v.json").write_text(json.dumps(data))
    argv = [
        "compare",
        "--cage",
        files / "cage.json",
        "--data",
        files / "v.json",
        "--output",
        files / "fig.png",
    ]
    code, out, err = run_main(argv, capfd)
    assert_one_line_error(code, err, pattern)
    assert not (files / "fig.png").exists()


# -- successful runs (need core.triangulate and core.mesh_basis_functions) -----------------


def domain_mask(control_points, inset, shape=(HEIGHT, WIDTH)):
    """Pixels whose centres are inside the B-spline domain by more than `inset` (negative: outside)."""
    from core import ClosedBSpline

    curve = ClosedBSpline(control_points)
    outline = curve(np.linspace(0, curve.n, 64 * curve.n, endpoint=False))
    mask = np.zeros(shape, dtype=np.uint8)
    cv2.fillPoly(mask, [np.round((outline - 0.5) * 256).astype(np.int32)], 1, shift=8)
    size = 2 * int(np.ceil(abs(inset))) + 1
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
    return cv2.erode(mask, kernel).astype(bool) if inset >= 0 else ~cv2.dilate(mask, kernel).astype(bool)


def psnr(a, b, mask):
    error = np.mean((a[mask][:, :3].astype(np.float64) - b[mask][:, :3]) ** 2)
    return 10 * np.log10(255.0**2 / max(error, 1e-12))


def test_warp_identity_reproduces_the_picture(files, capfd):
    code, out, err = run_main(warp_argv(files, **{"--target": files / "cage.json"}), capfd)
    assert code == 0, err
    result = read_image(files / "out.png")
    assert result.shape == (HEIGHT, WIDTH, 4)
    inside = domain_mask(CAGE, 1.5)
    assert psnr(result, picture(), inside) >= 40
    assert (result[inside, 3] == 255).all()
    assert (result[domain_mask(CAGE, -1.5), 3] == 0).all()
    assert "Traceback" not in err and out == ""


def test_warp_affine_target_matches_cv2(files, capfd):
    code, out, err = run_main(warp_argv(files), capfd)
    assert code == 0, err
    result = read_image(files / "out.png")
    # Linear precision: an affine move of the cage moves every point affinely.
    # OpenCV puts pixel centres at integers, we at +0.5 (see test_render).
    matrix, offset = AFFINE[:, :2], AFFINE[:, 2]
    opencv = np.hstack([matrix, (offset + (matrix - np.eye(2)) @ [0.5, 0.5])[:, None]])
    expected = cv2.warpAffine(picture(), opencv, (WIDTH, HEIGHT), flags=cv2.INTER_LINEAR)
    inside = domain_mask(transformed(CAGE), 2.0)
    assert inside.sum() > 3000
    assert psnr(result, expected, inside) >= 33
    assert (result[domain_mask(transformed(CAGE), -1.5), 3] == 0).all()


def test_warp_output_size_options(files, capfd):
    code, _, err = run_main([*warp_argv(files), "--scale", "0.5"], capfd)
    assert code == 0, err
    assert read_image(files / "out.png").shape == (HEIGHT // 2, WIDTH // 2, 4)
    code, _, err = run_main(
        [*warp_argv(files, **{"--target": files / "cage.json"}), "--size", "320x400"], capfd
    )
    assert code == 0, err
    result = read_image(files / "out.png")
    assert result.shape == (400, 320, 4)
    # Fitted: scale 2, centred vertically (offset 80), so the picture's centre pixel lands at (160, 200).
    assert np.abs(result[200, 160, :3].astype(int) - picture()[60, 80, :3]).max() <= 12


def test_warp_session_matches_explicit_arguments(files, capfd):
    code, _, err = run_main(warp_argv(files), capfd)
    assert code == 0, err
    explicit = read_image(files / "out.png")
    argv = ["warp", "--session", files / "session.json", "--output", files / "from_session.png"]
    code, _, err = run_main(argv, capfd)
    assert code == 0, err
    assert np.array_equal(read_image(files / "from_session.png"), explicit)


def test_warp_convex_only_kernel_on_a_non_convex_cage(files, capfd):
    code, _, err = run_main([*warp_argv(files), "--kernel", "wachspress"], capfd)
    assert_one_line_error(code, err, r"cage.json: kernel 'wachspress': .*convex")
    assert not (files / "out.png").exists()


def test_warp_end_to_end_in_a_subprocess(files):
    result = subprocess.run(
        [sys.executable, "-m", "app", *map(str, warp_argv(files)), "--max-edge", "12"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    assert read_image(files / "out.png").shape == (HEIGHT, WIDTH, 4)
    assert not list(files.glob(".out.png.*"))


def test_the_input_image_is_replaced_only_with_overwrite_input(files, capfd):
    source = (files / "picture.png").read_bytes()
    code, _, err = run_main(warp_argv(files, **{"--output": files / "picture.png"}), capfd)
    assert_one_line_error(code, err, r"is the input image")
    assert (files / "picture.png").read_bytes() == source
    argv = warp_argv(files, **{"--output": files / "picture.png", "--target": files / "cage.json"})
    code, _, err = run_main([*argv, "--overwrite-input"], capfd)
    assert code == 0, err
    assert (files / "picture.png").read_bytes() != source
    assert read_image(files / "picture.png").shape == (HEIGHT, WIDTH, 4)


def test_a_temporary_left_by_a_killed_warp_is_removed_by_the_next(files, capfd):
    finished = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True)
    stray = files / f".out.png.{int(finished.stdout)}.5eed1e55.tmp"  # what kill -9 mid-write leaves
    stray.write_bytes(b"half a PNG")
    code, _, err = run_main(warp_argv(files), capfd)
    assert code == 0, err
    assert not stray.exists()
    assert [p.name for p in files.glob(".out.png.*")] == []


def test_an_absurdly_large_target_warns(files, capfd):
    huge = (np.array(transformed(CAGE)) * 1e12).tolist()
    code, _, err = run_main(warp_argv(files, **{"--target": _cage(files, "t.json", huge)}), capfd)
    assert code == 0, err
    (line,) = [line for line in err.splitlines() if line.startswith("warning:")]
    assert re.search(r"t.json: the target spans 1.\d+e\+14 pixels, .* times the 160x120 output", line)
    code, _, err = run_main(warp_argv(files), capfd)
    assert code == 0 and "warning" not in err


CACHE_DAMAGE = {
    "truncated": lambda path: path.write_bytes(path.read_bytes()[:1000]),
    "random bytes": lambda path: path.write_bytes(np.random.default_rng(1).bytes(path.stat().st_size)),
    "random finite values": lambda path: _rewrite_basis(
        path, lambda basis: np.random.default_rng(2).uniform(0, 1, basis.shape)
    ),
    "two columns swapped": lambda path: _rewrite_basis(path, lambda basis: basis[:, [1, 0, *range(2, 8)]]),
    "one bit flipped": lambda path: _rewrite_basis(path, _flip_one_bit),
}


def _rewrite_basis(path, change):
    """Store a changed basis under the entry's old checksum, as a damaged disk or copy would."""
    with np.load(path) as entry:
        basis, errors, checksum = entry["basis"], entry["errors"], entry["checksum"]
    with open(path, "wb") as stream:
        np.savez(stream, basis=change(basis), errors=errors, checksum=checksum)


def _flip_one_bit(basis):
    damaged = basis.copy()
    damaged.reshape(-1).view(np.uint64)[len(basis) * 4 + 3] ^= np.uint64(1 << 40)
    return damaged


@pytest.mark.parametrize("damage", CACHE_DAMAGE)
def test_a_damaged_cache_entry_gives_the_reference_image_is_rewritten_and_reported(
    files, capfd, tmp_path_factory, monkeypatch, damage
):
    cache = tmp_path_factory.mktemp("damaged-cache")
    monkeypatch.setenv("TRANSFINITE_CACHE_DIR", str(cache))
    code, _, err = run_main(warp_argv(files, **{"--output": files / "reference.png"}), capfd)
    assert code == 0, err
    (entry,) = cache.glob("*.npz")
    intact = entry.read_bytes()
    CACHE_DAMAGE[damage](entry)
    assert entry.read_bytes() != intact
    code, _, err = run_main(warp_argv(files), capfd)
    assert code == 0, err
    assert (files / "out.png").read_bytes() == (files / "reference.png").read_bytes()
    assert entry.read_bytes() == intact  # rewritten: the same bytes as the first run wrote
    (line,) = [line for line in err.splitlines() if "cached basis functions" in line]
    assert re.fullmatch(
        rf"warning: the cached basis functions {re.escape(str(entry))} could not be used \(.+\); "
        r"recomputed them and replaced the file",
        line,
    )
    code, _, err = run_main(warp_argv(files), capfd)
    assert code == 0 and "cached basis functions" not in err


def test_compare_writes_table_and_figure(files, capfd):
    argv = ["compare", "--cage", files / "cage.json", "--output", files / "fig.png", "--max-edge", "8"]
    for kernel in ("harmonic-like", "mean-value", "wachspress"):
        argv += ["--kernel", kernel]
    code, out, err = run_main(argv, capfd)
    assert code == 0, err
    rows = {line.split()[0]: line.split() for line in out.strip().splitlines()[1:]}
    assert set(rows) == {"harmonic", "harmonic-like", "mean-value"}
    assert float(rows["harmonic"][1]) == 0.0
    for kernel in ("harmonic-like", "mean-value"):
        rms, maximum = float(rows[kernel][1]), float(rows[kernel][2])
        assert 0 < rms <= maximum < 0.3, "similar to the harmonic interpolant, but not the same"
    assert re.search(r"note: wachspress skipped: .*convex", err)
    figure = read_image(files / "fig.png")
    assert figure.shape[1] > 3 * 300 and (figure[..., 3] == 255).all()


# -- help texts ------------------------------------------------------------------------------


def subcommands(parser):
    (commands,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return commands.choices


def test_every_argument_of_every_command_has_help():
    parser = build_parser()
    missing = [
        f"{name} {'/'.join(action.option_strings) or action.dest}"
        for name, command in subcommands(parser).items()
        for action in command._actions
        if not action.help
    ]
    assert missing == []


@pytest.mark.parametrize("name", ["warp", "fit", "compare", "bench", "view", "demo"])
def test_help_has_a_plain_description_and_examples(name, capsys):
    command = subcommands(build_parser("transfinite-warp"))[name]
    text = command.format_help()
    assert text.startswith(f"usage: transfinite-warp {name} ")
    assert f"examples:\n  transfinite-warp {name}" in text
    description = command.description
    assert description and not re.search(r"``|`\w|:\w+:`", description), "no reStructuredText markup"


def test_kernel_options_list_their_choices():
    for name in ("warp", "compare"):
        text = " ".join(subcommands(build_parser())[name].format_help().split())
        assert all(kernel in text for kernel in kernel_names()), name


def test_the_demo_script_format_is_the_same_in_the_help_and_in_assets_readme():
    def words(text):
        return " ".join(text.split())

    demo_help = words(subcommands(build_parser())["demo"].format_help())
    assert words(SCRIPT_FORMAT) in demo_help
    assert words(SCRIPT_FORMAT) in words((ROOT / "assets" / "README.md").read_text())


def test_program_name():
    assert program_name("/usr/lib/python3/site-packages/app/__main__.py") == "python -m app"
    assert program_name("/home/me/.venv/bin/transfinite-warp") == "transfinite-warp"


def test_usage_names_the_program_as_it_was_started(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "app", "fit", "--help"], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0 and result.stdout.startswith("usage: python -m app fit ")


def cage_mask(points, inset: float) -> np.ndarray:
    """Pixels whose centres are inside the cage's curve by more than `inset` (< 0: outside by -inset)."""
    from app.viewer.editing import curve_points

    polygon = curve_points(np.asarray(points, float), 64)
    mask = np.zeros((HEIGHT, WIDTH), np.uint8)
    cv2.fillPoly(mask, [np.round((polygon - 0.5) * 16).astype(np.int32)], 1, shift=4)
    kernel = np.ones((2 * int(np.ceil(abs(inset))) + 1,) * 2, np.uint8)
    return (cv2.erode(mask, kernel) if inset > 0 else cv2.dilate(mask, kernel)).astype(bool)


def test_outside_original_keeps_the_picture_and_grow_widens_the_canvas(files, capfd):
    image = picture()
    (files / "same.json").write_text(json.dumps({"control_points": CAGE}))
    argv = warp_argv(files, **{"--target": files / "same.json"}) + ["--outside", "original"]
    assert run_main(argv, capfd)[0] == 0
    identity = read_image(files / "out.png")
    assert (identity[..., 3] == 255).all()
    assert np.abs(identity.astype(int) - image).max() <= 1  # the input, PSNR far above 40 dB
    shift = np.array([12.0, 7.0])
    moved_cage = (np.array(CAGE, float) + shift).tolist()
    (files / "moved.json").write_text(json.dumps({"control_points": moved_cage}))
    argv = warp_argv(files, **{"--target": files / "moved.json"}) + ["--outside", "original"]
    assert run_main(argv, capfd)[0] == 0
    moved = read_image(files / "out.png")
    away = ~cage_mask(CAGE, -2) & ~cage_mask(moved_cage, -2)
    np.testing.assert_array_equal(moved[away], image[away])  # exactly the input away from both cages
    ys, xs = np.nonzero(cage_mask(moved_cage, 2))
    inside = np.abs(moved[ys, xs].astype(int) - image[ys - 7, xs - 12]).mean()
    assert inside < 3  # the translated picture (bilinear resampling of a smooth image)
    assert run_main(warp_argv(files, **{"--target": files / "moved.json"}), capfd)[0] == 0
    assert (read_image(files / "out.png")[away, 3] == 0).all()  # the default stays transparent
    # A target that leaves the image on the left and at the bottom: grow widens the output.
    leaving = (np.array(CAGE, float) + [-40.0, 30.0]).tolist()
    (files / "leaving.json").write_text(json.dumps({"control_points": leaving}))
    argv = warp_argv(files, **{"--target": files / "leaving.json"}) + ["--canvas", "grow"]
    code, _, err = run_main(argv, capfd)
    assert code == 0, err
    grown = read_image(files / "out.png")
    from app.viewer.editing import curve_points

    curve = curve_points(np.array(leaving), 64)
    left, bottom = int(np.floor(curve[:, 0].min())), int(np.ceil(curve[:, 1].max()))
    assert grown.shape == (bottom, WIDTH - left, 4)
    assert grown[:, : -left - 1, 3].any()  # drawn where the input had no pixels
    code, out, _ = run_main(["warp", "--help"], capfd)
    help_text = " ".join(out.split())
    assert code == 0
    assert "--outside {transparent,original}" in help_text and "--canvas {source,grow}" in help_text
    assert "where the source cage's region is not covered by the deformed one, the original" in help_text


def test_a_session_carries_outside_and_canvas_to_warp(files, capfd):
    session = json.loads((files / "session.json").read_text())
    session.update(outside="original", canvas="grow")
    (files / "kept.json").write_text(json.dumps(session))
    code, _, err = run_main(["warp", "--session", files / "kept.json", "--output", files / "o.png"], capfd)
    assert code == 0, err
    assert (read_image(files / "o.png")[..., 3] == 255).all()  # the picture kept around the warp
    argv = ["warp", "--session", files / "kept.json", "--output", files / "t.png", "--outside", "transparent"]
    assert run_main(argv, capfd)[0] == 0
    assert (read_image(files / "t.png")[..., 3] == 0).any()  # the command line wins
    session["outside"] = "blurred"
    (files / "bad.json").write_text(json.dumps(session))
    code, _, err = run_main(["warp", "--session", files / "bad.json", "--output", files / "b.png"], capfd)
    assert code == 2 and err.strip() == (
        f"error: {files / 'bad.json'}: \"outside\" must be one of transparent, original, got 'blurred'"
    )
    assert not (files / "b.png").exists()


def test_demo_list_prints_where_the_bundled_files_are(capfd):
    code, out, _ = run_main(["demo", "--list"], capfd)
    assert code == 0
    paths = [Path(line.split(maxsplit=1)[1]) for line in out.splitlines() if line.startswith("  ")]
    assert len(paths) == 12 and all(path.is_file() for path in paths)
    assert {path.name for path in paths} >= {"starfish.png", "starfish.cage.json", "pattern.png"}


def test_view_refuses_an_unknown_kernel_before_opening_anything(tmp_path, capfd):
    code, _, err = run_main(["view", "--kernel", "bogus", "--session", tmp_path / "s.json"], capfd)
    assert code == 2 and re.match(r"error: unknown kernel 'bogus'; choose one of .*harmonic", err)
    assert not (tmp_path / "s.json").exists()


def test_a_session_whose_image_is_not_beside_it_says_where_it_looked(tmp_path, capfd):
    # A bundled session copied elsewhere: its relative "image" is looked for beside the copy.
    copy = tmp_path / "copied.session.json"
    copy.write_text((ROOT / "assets" / "starfish.session.json").read_text())
    warp = ["warp", "--session", copy, "--output", tmp_path / "out.png"]
    for argv in (warp, ["animate", copy, "--output", tmp_path / "o.gif"]):
        code, _, err = run_main(argv, capfd)
        assert code == 2, err
        assert err.strip() == (
            f"error: {copy}: its \"image\" 'starfish.png' is {tmp_path / 'starfish.png'}, which does not "
            'exist (a relative "image" is relative to the session file); copy the image there or write its '
            'path in "image"'
        )


def test_output_into_a_closed_pipe_ends_quietly():
    # `... | head`: the reader goes away; no traceback, the exit status of a SIGPIPE.
    command = [sys.executable, "-m", "app", "demo", "--list"]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=ROOT)
    process.stdout.close()
    _, err = process.communicate(timeout=120)
    assert process.returncode == 141, err
    assert err == b""


def test_a_broken_pipe_that_is_not_standard_output_is_not_silenced(monkeypatch, capfd):
    # The viewer's worker gone: its pipe breaks, standard output is fine, and that must show.
    import app.commands.cli

    def broken():
        raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(app.commands.cli, "_list_demos", broken)
    with pytest.raises(BrokenPipeError):
        app.commands.cli.main(["demo", "--list"])


def test_the_viewer_exports_to_a_still_or_an_animation_only(files, capfd):
    """``--export`` (where Ctrl+E writes) takes a PNG, or a GIF or MP4 of the keyframed animation."""
    code, _, err = run_main(["demo", "starfish", "--export", str(files / "out.bmp")], capfd)
    assert_one_line_error(code, err, r"out.bmp: the output file name must end in .png, .gif, .mp4")
