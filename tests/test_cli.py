"""Tests of the command line (app.cli, app.__main__, app.compare's command, the help texts).

Bad input must give exit code 2 and exactly one line on stderr naming the problem
and the file, no traceback, no output file, and an existing output untouched.
Most cases run `main(argv)` in-process (capfd also catches what C libraries print);
a few run ``python -m app`` in a subprocess end to end.
"""

import argparse
import json
import re
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from app.__main__ import main
from app.cli import build_parser, program_name
from app.files import kernel_names, read_cage, read_image, write_png
from app.viewer.demos import SCRIPT_FORMAT

ROOT = Path(__file__).resolve().parent.parent
WIDTH, HEIGHT = 160, 120
# A rounded, slightly non-convex cage well inside the picture (image pixels).
CAGE = [[30, 20], [80, 30], [130, 18], [140, 60], [128, 100], [80, 92], [28, 102], [20, 60]]
FIGURE_EIGHT = [[103, 74], [135, 74], [135, 46], [103, 46], [57, 74], [25, 74], [25, 46], [57, 46]]
L_AROUND_CORNER = [[-40, -40], [10, -40], [60, -40], [60, -12], [-12, -12], [-12, 60], [-40, 60], [-40, 10]]
AFFINE = np.array([[0.9, -0.2, 18.0], [0.15, 1.05, -6.0]])  # x' = A x + b, our pixel convention


def picture():
    y, x = np.mgrid[0:HEIGHT, 0:WIDTH].astype(np.float64)
    image = np.empty((HEIGHT, WIDTH, 4), dtype=np.uint8)
    image[..., 0] = 127.5 + 127 * np.sin(x / 7.0) * np.cos(y / 9.0)
    image[..., 1] = 255 * y / HEIGHT
    image[..., 2] = 127.5 + 127 * np.sin((x + y) / 11.0)
    image[..., 3] = 255
    return image


def transformed(points):
    points = np.asarray(points, dtype=float)
    return points @ AFFINE[:, :2].T + AFFINE[:, 2]


@pytest.fixture(autouse=True)
def private_cache(tmp_path_factory, monkeypatch):
    """Keep core's basis-function cache out of the home directory."""
    monkeypatch.setenv("TRANSFINITE_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))


@pytest.fixture
def files(tmp_path):
    """A picture, a cage, an affine target and a session, all valid, in tmp_path."""
    write_png(tmp_path / "picture.png", picture())
    (tmp_path / "cage.json").write_text(json.dumps({"control_points": CAGE}))
    (tmp_path / "target.json").write_text(json.dumps({"control_points": transformed(CAGE).tolist()}))
    session = {
        "image": "picture.png",
        "cage": {"control_points": CAGE},
        "target": {"control_points": transformed(CAGE).tolist()},
        "kernel": "harmonic-like",
        "view": {"scale": 2.0, "offset": [10, 5]},
    }
    (tmp_path / "session.json").write_text(json.dumps(session))
    return tmp_path


def run_main(argv, capfd):
    code = main([str(a) for a in argv])
    out, err = capfd.readouterr()
    return code, out, err


def warp_argv(d, **replace):
    arguments = {
        "image": d / "picture.png",
        "--cage": d / "cage.json",
        "--target": d / "target.json",
        "--output": d / "out.png",
    }
    arguments.update(replace)
    argv = ["warp"]
    for key, value in arguments.items():
        if value is None:
            continue
        argv += [value] if key == "image" else [key, value]
    return argv


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
    "output not PNG": (lambda d: warp_argv(d, **{"--output": d / "out.jpg"}), r"out.jpg: .*must end in .png"),
    "missing --cage": (lambda d: warp_argv(d, **{"--cage": None}), r"warp needs --cage \(or --session\)"),
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
        r"gone.png: no such file",
    ),
    "bad --size": (lambda d: [*warp_argv(d), "--size", "12by4"], r"--size: expected WIDTHxHEIGHT"),
    "negative --scale": (lambda d: [*warp_argv(d), "--scale", "-2"], r"--scale: must be a finite number > 0"),
    "missing --output": (lambda d: warp_argv(d, **{"--output": None}), r"required: --output"),
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
    monkeypatch.setattr("app.bench.run_bench", lambda args: calls.append(args) or 0)
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
    assert [(options.stats, options.max_edge) for options in opened] == [(True, 20.0)]


@pytest.mark.parametrize(
    "argv, message",
    [
        (["demo", "nosuch"], r"unknown demo 'nosuch'; choose one of starfish, character, pattern"),
        (["view", "--cage", "cage.json"], r"--cage needs an IMAGE"),
        (["view", "missing.png"], r"missing.png: no such file"),
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


@pytest.mark.parametrize(
    "argv, pattern",
    [
        (["fit", "{d}/empty.png", "--output", "{d}/cage.json"], r"empty.png: found no object in the image"),
        (
            ["fit", "{d}/blob.png", "--output", "{d}/cage.txt"],
            r"cage.txt: the output file name must end in .json",
        ),
        (
            ["fit", "{d}/blob.png", "--output", "{d}/cage.json", "--points", "2"],
            r"blob.png: points must be at least 3",
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
