"""Bad numbers, sizes, file kinds and paths at every command (issue 23): one line, the right exit code.

`test_generated_bad_input` throws a few hundred generated bad inputs (fixed seed) at
every command through `app.__main__.main` in-process: each must end with exactly
one line on stderr, naming where the problem is, exit code 2, no traceback, and
every file in the folder exactly as it was (no output, no temporary, no input
touched).  The other tests are the cases of the issue that need a process of their
own (an address-space limit) or more than one line to state.
"""

import hashlib
import io
import json
import os
import random
import re
import resource
import stat
import subprocess
import sys
import time
import zlib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from support.commands import CAGE, picture, transformed
from support.paths import ROOT

from app.__main__ import main
from app.io.files import write_png

#: An integer of 401 digits: beyond float's range, which JSON does not know.
HUGE = "1" * 401
SESSION = {
    "image": "picture.png",
    "cage": {"control_points": CAGE},
    "target": {"control_points": transformed(CAGE).tolist()},
    "kernel": "power",
    "kernel_params": {"power": 3.0, "shift": "mean"},
    "mesh": {"max_edge": 12.0},
    "view": {"scale": 2.0, "offset": [10, 5]},
    "keyframes": [
        {"time": 0, "target": {"control_points": CAGE}},
        {"time": 1.5, "target": {"control_points": transformed(CAGE).tolist()}},
    ],
}
SCRIPT = {"moves": [{"at": 0.5, "duration": 1.0, "point": 2, "to": [60, 40]}]}


@pytest.fixture(scope="module")
def originals(tmp_path_factory):
    """The valid files every case starts from (written once; `folder` copies them)."""
    directory = tmp_path_factory.mktemp("originals")
    write_png(directory / "picture.png", picture())
    from PIL import Image

    Image.fromarray(picture()[..., :3]).save(directory / "picture.gif")
    texts = {
        "cage.json": {"control_points": CAGE},
        "target.json": {"control_points": transformed(CAGE).tolist()},
        "session.json": SESSION,
        "gif-session.json": {**SESSION, "image": "picture.gif"},
        "data.json": {"values": [0.1 * i for i in range(len(CAGE))]},
        "script.json": SCRIPT,
    }
    for name, value in texts.items():
        (directory / name).write_text(json.dumps(value))
    return {path.name: path.read_bytes() for path in directory.iterdir()}


@pytest.fixture
def folder(tmp_path, originals, monkeypatch):
    """A folder with the valid files and the odd ones: a FIFO, an empty file, binary junk, text
    that is not JSON, a symbolic link to itself, a subfolder; the viewer's state elsewhere."""
    for name, data in originals.items():
        (tmp_path / name).write_bytes(data)
    os.mkfifo(tmp_path / "fifo")
    (tmp_path / "empty.json").write_bytes(b"")
    (tmp_path / "junk.bin").write_bytes(bytes(range(256)) * 4)
    (tmp_path / "text.txt").write_text("not JSON, not an image\n")
    os.symlink("loop", tmp_path / "loop")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "kept.txt").write_text("a file of the user's")
    monkeypatch.setenv("TRANSFINITE_STATE_DIR", str(tmp_path.parent / f"{tmp_path.name}-state"))
    monkeypatch.setenv("TRANSFINITE_CACHE_DIR", str(tmp_path.parent / f"{tmp_path.name}-cache"))
    monkeypatch.chdir(tmp_path)
    return tmp_path


def snapshot(directory: Path) -> dict:
    """Every entry under `directory`: its kind, and the SHA-256 and mode of a regular file."""
    state = {}
    for path in sorted(directory.rglob("*")):
        status = os.lstat(path)
        entry = stat.S_IFMT(status.st_mode)
        if stat.S_ISREG(status.st_mode):
            entry = (entry, hashlib.sha256(path.read_bytes()).hexdigest(), status.st_mode, status.st_mtime_ns)
        state[str(path.relative_to(directory))] = entry
    return state


# -- the bad values ----------------------------------------------------------------------

#: Command-line numbers that no positive, finite option takes.
BAD_NUMBERS = ["0", "-1", "nan", "inf", "-inf", "1e999", "", "abc", "1,5", HUGE, "-" + HUGE, "1e-400", "0x10"]
#: Command-line integers that no count (>= 1) takes.
BAD_COUNTS = ["0", "-1", "1.5", "nan", "", "abc", "1e3", "-" + HUGE]
#: Sizes WxH that no output may have.
BAD_SIZES = [
    "0x0",
    "-1x5",
    "5x-1",
    "16384x16384",
    "99999x99999",
    "1x" + HUGE,
    "axb",
    "",
    "12",
    "1x2x3",
    "nanx3",
]
#: JSON values (as text) that no number of a session, cage, data or script file may be.
BAD_JSON_NUMBERS = [
    HUGE,
    "-" + HUGE,
    "1e999",
    "-1e999",
    "NaN",
    "Infinity",
    "true",
    '"3"',
    "null",
    "[1]",
    "{}",
]
#: Input files of the wrong kind: (path, what the message names).
BAD_FILES = [
    "missing.json",
    "sub",
    "/dev/zero",
    "fifo",
    "empty.json",
    "junk.bin",
    "text.txt",
    "loop",
    "x" * 300 + ".json",
    "picture.png/inside.json",
]
#: Output paths that cannot or must not be written.
BAD_OUTPUTS = ["nowhere/out.{ext}", "y" * 300 + ".{ext}", "sub", "loop/out.{ext}", "picture.png/out.{ext}"]


def with_json(directory: Path, name: str, edit, value: str) -> Path:
    """A copy of `name` in which `edit(data)` put a marker that becomes the raw JSON `value`."""
    data = json.loads((directory / name).read_text())
    edit(data)
    path = directory / f"bad-{name}"
    path.write_text(json.dumps(data).replace('"@BAD@"', value))
    return path


def put(*keys):
    """An edit setting data[k1][k2]... to the marker."""

    def edit(data):
        for key in keys[:-1]:
            data = data[key]
        data[keys[-1]] = "@BAD@"

    return edit


def warp(d, **options):
    """warp's arguments: IMAGE --cage --target --output, with `options` replacing or adding some."""
    arguments = {"image": d / "picture.png", "--cage": d / "cage.json", "--target": d / "target.json"}
    arguments |= {"--output": d / "out.png", **options}
    argv = ["warp"]
    for name, value in arguments.items():
        argv += [value] if name == "image" else [name, value]
    return argv


def animate(d, session="session.json", *extra):
    return ["animate", d / session, "--output", d / "movie.gif", *extra]


#: Each slot: (command, where the error must point, a function (folder, bad value) -> argv, the values).
SLOTS = [
    ("warp", "--scale", lambda d, v: [*warp(d), "--scale", v], [*BAD_NUMBERS, "1e300", "200"]),
    ("warp", "--max-edge", lambda d, v: [*warp(d), "--max-edge", v], BAD_NUMBERS),
    ("warp", "--size|output size", lambda d, v: [*warp(d), "--size", v], BAD_SIZES),
    (
        "warp",
        "--samples-per-segment",
        lambda d, v: [*warp(d), "--samples-per-segment", v],
        [*BAD_COUNTS, "1"],
    ),
    ("warp", "", lambda d, v: warp(d, image=d / v), BAD_FILES),
    ("warp", "", lambda d, v: warp(d, **{"--cage": d / v}), BAD_FILES),
    ("warp", "", lambda d, v: warp(d, **{"--target": d / v}), BAD_FILES),
    ("warp", "", lambda d, v: warp(d, **{"--output": d / v.format(ext="png")}), BAD_OUTPUTS),
    (
        "warp",
        "picture.png|cage.json|target.json",
        lambda d, v: warp(d, **{"--output": d / v}),
        ["picture.png", "cage.json", "target.json"],
    ),
    (
        "warp",
        "cage.json",
        lambda d, v: warp(d, **{"--cage": with_json(d, "cage.json", put("control_points", 3, 0), v)}),
        BAD_JSON_NUMBERS,
    ),
    *(
        (
            "warp",
            "session.json",
            lambda d, v, keys=keys: [
                "warp",
                "--session",
                with_json(d, "session.json", put(*keys), v),
                "--output",
                d / "out.png",
            ],
            BAD_JSON_NUMBERS,
        )
        for keys in (
            ("view", "scale"),
            ("view", "offset", 0),
            ("kernel_params", "power"),
            ("mesh", "max_edge"),
            ("cage", "control_points", 0, 1),
        )
    ),
    ("warp", "", lambda d, v: ["warp", "--session", d / v, "--output", d / "out.png"], BAD_FILES),
    (
        "warp",
        "",
        lambda d, v: [
            "warp",
            "--session",
            with_json(d, "session.json", put("image"), json.dumps(str(d / v))),
            "--output",
            d / "out.png",
        ],
        BAD_FILES,
    ),
    (
        "fit",
        "--points",
        lambda d, v: ["fit", d / "picture.png", "--output", d / "fitted.json", "--points", v],
        [*BAD_COUNTS, "100000"],
    ),
    ("fit", "", lambda d, v: ["fit", d / v, "--output", d / "fitted.json"], BAD_FILES),
    ("fit", "", lambda d, v: ["fit", d / "picture.png", "--output", d / v.format(ext="json")], BAD_OUTPUTS),
    (
        "fit",
        "--rect",
        lambda d, v: ["fit", d / "picture.png", "--output", d / "fitted.json", "--rect", v],
        ["1,2,3", "a,b,c,d", f"0,0,{HUGE},10", "nan,0,5,5", "0,0,-5,5", "500,500,5,5"],
    ),
    ("compare", "", lambda d, v: ["compare", "--cage", d / v, "--output", d / "figure.png"], BAD_FILES),
    (
        "compare",
        "",
        lambda d, v: ["compare", "--cage", d / "cage.json", "--data", d / v, "--output", d / "figure.png"],
        BAD_FILES,
    ),
    (
        "compare",
        "data.json",
        lambda d, v: [
            "compare",
            "--cage",
            d / "cage.json",
            "--data",
            with_json(d, "data.json", put("values", 2), v),
            "--output",
            d / "figure.png",
        ],
        BAD_JSON_NUMBERS,
    ),
    (
        "compare",
        "--max-edge",
        lambda d, v: ["compare", "--cage", d / "cage.json", "--output", d / "figure.png", "--max-edge", v],
        BAD_NUMBERS,
    ),
    (
        "compare",
        "",
        lambda d, v: ["compare", "--cage", d / "cage.json", "--output", d / v.format(ext="png")],
        BAD_OUTPUTS,
    ),
    (
        "compare",
        "--kernel|unknown kernel",
        lambda d, v: ["compare", "--cage", d / "cage.json", "--output", d / "figure.png", "--kernel", v],
        ["nosuch", "", "POWER"],
    ),
    ("quality", "--seed", lambda d, v: ["quality", "--seed", v], ["-1", "1.5", "abc", "", "-" + HUGE]),
    (
        "quality",
        "--kernel",
        lambda d, v: ["quality", "--kernel", v],
        [
            "nosuch",
            "power:power=0",
            "power:power=nan",
            f"power:power={HUGE}",
            "power:shift=sideways",
            "mean-value:x=1",
            "harmonic-like:parameterization=sideways",
            "power:=3",
            "pgw:angles=0",
            "pgw:angles=8.5",
            "harmonic:angles=3",
            "poisson:power=2",
        ],
    ),
    ("quality", "--domain", lambda d, v: ["quality", "--domain", v], ["nosuch", ""]),
    (
        "quality",
        "",
        lambda d, v: ["quality", "--output", d / v.format(ext="png")],
        [*BAD_OUTPUTS, "quality.txt"],
    ),
    ("bench", "--repeats", lambda d, v: ["bench", "--quick", "--repeats", v], BAD_COUNTS),
    ("animate", "--fps", lambda d, v: [*animate(d), "--fps", v], [*BAD_NUMBERS, "1e-9", "5000"]),
    ("animate", "--size|output size", lambda d, v: [*animate(d), "--size", v], BAD_SIZES),
    ("animate", "--max-edge", lambda d, v: [*animate(d), "--max-edge", v], BAD_NUMBERS),
    ("animate", "", lambda d, v: animate(d, v), BAD_FILES),
    (
        "animate",
        "",
        lambda d, v: ["animate", d / "session.json", "--output", d / v.format(ext="gif")],
        [*BAD_OUTPUTS, "movie.txt"],
    ),
    (
        "animate",
        "gif-session.json|picture.gif",
        lambda d, v: ["animate", d / "gif-session.json", "--output", d / v],
        ["picture.gif", "gif-session.json"],
    ),
    *(
        (
            "animate",
            "session.json",
            lambda d, v, keys=keys: animate(d, with_json(d, "session.json", put(*keys), v).name),
            BAD_JSON_NUMBERS,
        )
        for keys in (
            ("keyframes", 1, "time"),
            ("keyframes", 0, "target", "control_points", 2, 0),
            ("view", "scale"),
        )
    ),
    ("view", "", lambda d, v: ["view", d / v], BAD_FILES),
    ("view", "", lambda d, v: ["view", d / "picture.png", "--cage", d / v], BAD_FILES),
    ("view", "--max-edge", lambda d, v: ["view", d / "picture.png", "--max-edge", v], BAD_NUMBERS),
    ("view", "--vertices", lambda d, v: ["view", d / "picture.png", "--vertices", v], BAD_COUNTS),
    (
        "view",
        "",
        lambda d, v: ["view", d / "picture.png", "--export", d / v.format(ext="png")],
        [*BAD_OUTPUTS, "picture.png"],
    ),
    (
        "view",
        "",
        lambda d, v: ["view", d / "picture.png", "--session", d / v.format(ext="json")],
        [*BAD_OUTPUTS[:2], "sub"],
    ),
    ("demo", "demo", lambda d, v: ["demo", v], ["nosuch", "../starfish", "STARFISH", "starfish.png"]),
    ("demo", "--fps", lambda d, v: ["demo", "--fps", v], [*BAD_NUMBERS, "1e-9"]),
    ("demo", "", lambda d, v: ["demo", "--script", d / v], BAD_FILES),
    (
        "demo",
        "script.json",
        lambda d, v: ["demo", "--script", with_json(d, "script.json", put("moves", 0, "at"), v)],
        BAD_JSON_NUMBERS,
    ),
    (
        "demo",
        "script.json",
        lambda d, v: ["demo", "--script", with_json(d, "script.json", put("moves", 0, "to", 1), v)],
        BAD_JSON_NUMBERS,
    ),
    ("demo", "", lambda d, v: ["demo", "--export", d / v.format(ext="png")], BAD_OUTPUTS),
    ("demo", "--frames", lambda d, v: ["demo", "--frames", d / v], ["picture.png"]),
]


def generated_cases(seed: int = 23) -> list[tuple[str, str, int, str]]:
    """(command, where, slot index, value) of every slot and bad value, in a fixed shuffled order."""
    cases = [
        (command, where, index, value)
        for index, (command, where, _, values) in enumerate(SLOTS)
        for value in values
    ]
    random.Random(seed).shuffle(cases)
    return cases


CASES = generated_cases()


def test_the_fuzz_covers_every_command_with_hundreds_of_inputs():
    assert len(CASES) >= 200
    assert {case[0] for case in CASES} == {
        "warp",
        "fit",
        "compare",
        "quality",
        "bench",
        "animate",
        "view",
        "demo",
    }


@pytest.mark.parametrize("case", CASES, ids=[f"{c[0]}-{c[2]}-{c[3][:24]!r}" for c in CASES])
def test_generated_bad_input(folder, capfd, monkeypatch, case):
    command, where, index, value = case
    # Reaching a window, a study or a benchmark would be a bad input taken for a good one.
    monkeypatch.setattr("app.viewer.window.run", lambda *arguments: pytest.fail("the viewer opened"))
    monkeypatch.setattr(
        "app.studies.quality.run_study", lambda *arguments, **keywords: pytest.fail("ran the study")
    )
    monkeypatch.setattr("app.bench.table.run_bench", lambda *arguments: pytest.fail("ran the bench"))
    argv = [str(part) for part in SLOTS[index][2](folder, value)]
    before = snapshot(folder)
    started = time.perf_counter()
    code = main(argv)
    elapsed = time.perf_counter() - started
    out, err = capfd.readouterr()
    lines = err.strip().splitlines()
    assert len(lines) == 1, f"{argv}: expected one line on stderr, got:\n{err}"
    assert "Traceback" not in err and out == ""
    assert code == 2, f"{argv}: exit {code}: {lines[0]}"
    assert "error" in lines[0]
    if where:
        assert any(name in lines[0] for name in where.split("|")), lines[0]
    assert snapshot(folder) == before, f"{argv} changed a file"
    assert elapsed < 10, f"{argv} took {elapsed:.1f} s to refuse"


# -- the cases of issue 23 that need more ----------------------------------------------------


def run_limited(argv, address_space, cwd):
    """``python -m app ARGV`` with its address space limited like ``prlimit --as``."""
    limit = (int(address_space), int(address_space))
    return subprocess.run(
        [sys.executable, "-m", "app", *map(str, argv)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_AS, limit),
    )


@pytest.mark.parametrize(
    ("gib", "pattern"),
    [
        (
            0.75,
            r"^error: out of memory: the address space is limited to 0.75 GiB \(ulimit -v\); the program",
        ),
        (1.2, r"^error: out of memory: "),
    ],
)
def test_lack_of_address_space_is_one_line_and_exit_1(folder, gib, pattern):
    # 0.75 GiB: OpenBLAS spun forever loading scipy; 1.2 GiB: llvmpipe crashed (SIGSEGV) in
    # program() or, lower, the message blamed a missing libEGL.
    before = snapshot(folder)
    result = run_limited(warp(folder), gib * 2**30, folder)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and result.returncode == 1, result.stderr
    assert __import__("re").search(pattern, lines[0]), lines[0]
    assert snapshot(folder) == before


def test_the_renderers_need_is_checked_before_the_gl_context(folder, capfd, monkeypatch):
    monkeypatch.setattr("app.render.address_space.address_space_limit", lambda: 2 << 30)
    monkeypatch.setattr("app.render.address_space.address_space_left", lambda: 1 << 30)
    monkeypatch.setattr(
        "app.render.renderer.moderngl.create_context", lambda **keywords: pytest.fail("made a context")
    )
    before = snapshot(folder)
    code = main([str(a) for a in [*warp(folder), "--size", "8000x8000"]])
    (line,) = capfd.readouterr().err.strip().splitlines()
    assert code == 1
    assert line.startswith(
        "error: out of memory: an OpenGL context and drawing the 160x120 image into 8000x8000 pixels needs "
        "about 1."
    ), line
    assert line.endswith("of address space, but the limit of 2.00 GiB (ulimit -v) leaves 1.00 GiB")
    assert snapshot(folder) == before


def test_a_cage_of_a_million_points_is_refused_before_its_points_are_checked(folder, capfd):
    # The text json.dumps writes for the points (i, 0), i < 1,000,000, put together 5x faster.
    points = ", ".join(f"[{i}.0, 0.0]" for i in range(1_000_000))
    (folder / "million.json").write_text(f'{{"control_points": [{points}]}}')
    started = time.perf_counter()
    code = main([str(a) for a in warp(folder, **{"--cage": folder / "million.json"})])
    assert time.perf_counter() - started < 10  # it was 100 s and 8 GB
    (line,) = capfd.readouterr().err.strip().splitlines()
    assert code == 2
    assert line.endswith(
        "million.json: 1,000,000 control points need at least 2,000,000 boundary samples, more than the "
        "1,048,576 allowed; use at most 524,288 control points"
    )


def test_a_cage_too_large_for_its_samples_is_refused_before_meshing(folder, capfd, monkeypatch):
    monkeypatch.setattr("core.triangulate", lambda *arguments, **keywords: pytest.fail("meshed"))
    angles = np.linspace(0, 2 * np.pi, 20_000, endpoint=False)
    points = np.column_stack([80 + 50 * np.cos(angles), 60 + 50 * np.sin(angles)]).tolist()
    (folder / "dense.json").write_text(json.dumps({"control_points": points}))
    code = main(
        [str(a) for a in warp(folder, **{"--cage": folder / "dense.json", "--target": folder / "dense.json"})]
    )
    (line,) = capfd.readouterr().err.strip().splitlines()
    assert code == 2
    assert (
        "dense.json: samples_per_segment=100 gives 2,000,000 boundary samples for 20000 control points"
        in line
    )


def test_an_output_name_of_255_bytes_is_written(folder, capfd):
    # The temporary name is shortened: it went over 255 bytes and the write failed.
    for length in (245, 255):
        output = folder / ("n" * (length - 4) + ".png")
        assert main([str(a) for a in warp(folder, **{"--output": output})]) == 0
        assert output.stat().st_size > 0
    assert not [path for path in folder.iterdir() if path.name.endswith(".tmp")]


def test_animate_refuses_to_overwrite_the_sessions_image(folder, capfd):
    before = (folder / "picture.gif").read_bytes()
    code = main(["animate", str(folder / "gif-session.json"), "--output", str(folder / "picture.gif")])
    (line,) = capfd.readouterr().err.strip().splitlines()
    assert code == 2
    assert line.endswith(
        "picture.gif: is the session's image; give another output, inputs are never overwritten"
    )
    assert (folder / "picture.gif").read_bytes() == before


def test_quality_takes_integer_parameters_as_integers():
    from app.studies.quality import parse_kernel

    choice = parse_kernel("pgw:angles=8")
    assert choice.params == {"angles": 8} and isinstance(choice.params["angles"], int)
    assert parse_kernel("power:power=2").params == {"power": 2}


def test_outputs_up_to_the_pixel_limit_are_framed_and_drawn_in_tiles():
    # 11585 x 11585 (a valid image at scale 1) failed as "framebuffer is not complete": llvmpipe
    # refuses a multisampled framebuffer over 2 GiB although its largest renderbuffer is 16384.
    from app.render.renderer import MAX_OUTPUT_PIXELS, TILE
    from app.warp.framing import output_frame

    assert 11585 * 11585 <= MAX_OUTPUT_PIXELS and TILE * TILE * 4 * 4 < 2**31
    assert output_frame((0, 0, 11585, 11585))[0] == (11585, 11585)
    with pytest.raises(ValueError, match=r"the output would be 16384x16384 pixels \(268 megapixels\)"):
        output_frame((0, 0, 100, 100), size=(16384, 16384))


def _photo_bytes(format: str, **options) -> bytes:
    """A 160 x 120 photograph (test_cli's picture) encoded by Pillow."""
    stream = io.BytesIO()
    Image.fromarray(picture()[..., :3]).save(stream, format=format, **options)
    return stream.getvalue()


def _exif(orientation) -> bytes:
    exif = Image.Exif()
    exif[0x0112] = orientation
    return exif.tobytes()


def _png_with_chunk(kind: bytes, payload: bytes) -> bytes:
    from app.io.images.writing import png_chunk

    data = _photo_bytes("PNG")
    return data[:33] + png_chunk(kind, payload) + data[33:]


def _jpeg_declaring(width: int, height: int) -> bytes:
    """A JPEG whose frame header declares `width` x `height` and whose data is cut short."""
    data = _photo_bytes("JPEG")
    start = next(i for i in range(2, len(data) - 9) if data[i] == 0xFF and data[i + 1] == 0xC0)
    return (
        data[: start + 5]
        + height.to_bytes(2, "big")
        + width.to_bytes(2, "big")
        + data[start + 9 : start + 200]
    )


#: Bad photographs (issue 36): the file's bytes, the exit code, and the one line on stderr.
BAD_PHOTOGRAPHS = {
    "truncated JPEG": (lambda: _photo_bytes("JPEG")[:900], 2, r"photo: cannot decode the image"),
    "truncated TIFF": (
        lambda: _photo_bytes("TIFF", compression="tiff_lzw")[:20000],
        2,
        r"photo: cannot decode the image",
    ),
    "truncated WebP": (lambda: _photo_bytes("WEBP")[:300], 2, r"photo: cannot decode the image"),
    "JPEG bomb": (
        lambda: _jpeg_declaring(60000, 60000),
        2,
        r"photo: the JPEG image is 60000x60000 pixels \(3600 megapixels\); at most 134 megapixels",
    ),
    "orientation 9": (
        lambda: _photo_bytes("JPEG", exif=_exif(9)),
        0,
        r"photo: its EXIF orientation 9 is not one of 1-8; ignored",
    ),
    "malformed EXIF": (
        lambda: _photo_bytes("JPEG", exif=b"Exif\x00\x00MM\x00*\x00\x00\xff\xf0"),
        0,
        r"photo: its EXIF block is malformed \(its first IFD is beyond the block's end\); dropped",
    ),
    "garbage ICC profile": (
        lambda: _photo_bytes("JPEG", icc_profile=b"not a profile" * 20),
        0,
        r"photo: its ICC profile is not a valid profile \(no 'acsp' signature\); carried over unchanged",
    ),
    "ICC profile over 16 MB": (
        lambda: _png_with_chunk(b"iCCP", b"big\x00\x00" + zlib.compress(bytes(17 << 20))),
        0,
        r"photo: its ICC profile is more than 16 MiB; dropped",
    ),
    "two-page TIFF": (
        lambda: _photo_bytes("TIFF", save_all=True, append_images=[Image.new("RGB", (8, 8))]),
        0,
        r"photo: the TIFF has 2 pages; only the first is read",
    ),
}


@pytest.mark.parametrize("case", list(BAD_PHOTOGRAPHS))
def test_bad_photographs_are_one_line(folder, capfd, case):
    make, code, pattern = BAD_PHOTOGRAPHS[case]
    (folder / "photo").write_bytes(make())
    capfd.readouterr()
    assert main([str(a) for a in warp(folder, image=folder / "photo")]) == code
    lines = [line for line in capfd.readouterr().err.strip().splitlines() if f"{folder / 'photo'}:" in line]
    assert len(lines) == 1 and re.search(pattern, lines[0]), lines
    assert (folder / "out.png").exists() == (code == 0)


def test_the_viewer_without_a_display_is_one_line_and_leaves_no_worker(tmp_path):
    # The viewer's workers start before the window (app.viewer.precompute.start_method): without a
    # display they are ended before the error.  `run` collects the output until every process
    # holding its pipes has ended, a worker left behind included.
    environment = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    environment.update(TRANSFINITE_STATE_DIR=str(tmp_path / "state"), TRANSFINITE_CACHE_DIR=str(tmp_path))
    command = ["view", str(ROOT / "assets/starfish.png"), "--cage", str(ROOT / "assets/starfish.cage.json")]
    result = subprocess.run(
        [sys.executable, "-m", "app", *command], capture_output=True, text=True, env=environment, timeout=60
    )
    assert result.returncode == 1, result.stderr
    assert result.stderr.strip().count("\n") == 0 and "is there a display?" in result.stderr
