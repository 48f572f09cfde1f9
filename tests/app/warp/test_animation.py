"""``python -m app animate``: a session's keyframes as PNG frames, MP4 or GIF (app.warp.animation)."""

import json
import os
import re
import signal
import time

import cv2
import numpy as np
import pytest
from support import warm_start
from support.commands import CAGE, picture, run_main, transformed
from support.paths import ROOT

from app.io.files import read_image, write_png
from app.warp.frame_writers import GifWriter, flatten, gif_delay
from app.warp.framing import output_region


@pytest.fixture(autouse=True)
def private_cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("TRANSFINITE_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))


def session(target, keyframes=None, **extra) -> dict:
    value = {
        "image": "picture.png",
        "cage": {"control_points": CAGE},
        "target": {"control_points": np.asarray(target).tolist()},
        "kernel": "harmonic-like",
        "view": {"scale": 1.0, "offset": [0, 0]},
        **extra,
    }
    if keyframes is not None:
        value["keyframes"] = [
            {"time": t, "target": {"control_points": np.asarray(p).tolist()}} for t, p in keyframes
        ]
    return value


@pytest.fixture(scope="module")
def animation(tmp_path_factory):
    """A picture, a session with two keyframes (identity at 0 s, an affine move at 1 s), and the
    `warp` of each keyframe's target."""
    folder = tmp_path_factory.mktemp("animate")
    write_png(folder / "picture.png", picture())
    moved = transformed(CAGE)
    (folder / "two.json").write_text(json.dumps(session(CAGE, [(0.0, CAGE), (1.0, moved)])))
    (folder / "first.json").write_text(json.dumps(session(CAGE)))
    (folder / "last.json").write_text(json.dumps(session(moved)))
    for name in ("first", "last"):
        main_ok(["warp", "--session", folder / f"{name}.json", "--output", folder / f"{name}.png"])
    return folder


def main_ok(argv):
    from app.__main__ import main

    assert main([str(a) for a in argv]) == 0


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    error = np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)
    return float(10 * np.log10(255.0**2 / error))


def test_png_frames_match_warp_exactly_and_move_monotonically(animation, capfd):
    output = animation / "frames"
    code, _, err = run_main(
        ["animate", animation / "two.json", "--output", f"{output}/", "--fps", "10"], capfd
    )
    assert code == 0, err
    assert "11 frames of 160x120 at 10 fps" in err
    names = sorted(path.name for path in output.iterdir())
    assert names == [f"frame_{k:05d}.png" for k in range(11)]
    frames = [read_image(output / name) for name in names]
    np.testing.assert_array_equal(frames[0], read_image(animation / "first.png"))
    np.testing.assert_array_equal(frames[-1], read_image(animation / "last.png"))
    # The deformed region (alpha) moves from the first pose to the last one, never back.
    centroids = []
    for frame in frames:
        alpha = frame[..., 3].astype(np.float64)
        rows, cols = np.mgrid[0 : alpha.shape[0], 0 : alpha.shape[1]]
        centroids.append([(cols * alpha).sum() / alpha.sum(), (rows * alpha).sum() / alpha.sum()])
    centroids = np.array(centroids)
    direction = centroids[-1] - centroids[0]
    progress = (centroids - centroids[0]) @ direction / (direction @ direction)
    assert np.all(np.diff(progress) > 0), progress
    # The default interpolation eases in and out: the middle steps are the longest.
    assert np.diff(progress)[5] > 2 * np.diff(progress)[0]


def test_mp4_and_gif_match_warp_after_compression(animation, capfd):
    expected = [flatten(read_image(animation / f"{name}.png")) for name in ("first", "last")]
    for suffix in ("mp4", "gif"):
        output = animation / f"out.{suffix}"
        code, _, err = run_main(["animate", animation / "two.json", "--output", output, "--fps", "10"], capfd)
        assert code == 0, err
        if suffix == "mp4":
            video, frames = cv2.VideoCapture(str(output)), []
            while (read := video.read())[0]:
                frames.append(cv2.cvtColor(read[1], cv2.COLOR_BGR2RGB))
        else:
            from PIL import Image, ImageSequence

            with Image.open(output) as gif:
                assert gif.info["loop"] == 0 and gif.info["duration"] == 100
                frames = [np.asarray(frame.convert("RGB")) for frame in ImageSequence.Iterator(gif)]
        assert len(frames) == 11
        assert psnr(frames[0], expected[0]) >= 30, suffix
        assert psnr(frames[-1], expected[1]) >= 30, suffix
        assert not [p.name for p in animation.iterdir() if p.name.startswith(".")]  # no temporaries


def test_background_fills_frames_as_warp_does(animation, capfd):
    # PNG frames: exactly warp --background's output for the first and last targets, all opaque.
    output = animation / "blue"
    argv = [
        "animate",
        animation / "two.json",
        "--output",
        f"{output}/",
        "--fps",
        "2",
        "--background",
        "#0000ff",
    ]
    code, _, err = run_main(argv, capfd)
    assert code == 0, err
    frames = [read_image(path) for path in sorted(output.iterdir())]
    assert len(frames) == 3 and all((frame[..., 3] == 255).all() for frame in frames)
    for name, frame in (("first", frames[0]), ("last", frames[-1])):
        warped = animation / f"{name}-blue.png"
        main_ok(
            ["warp", "--session", animation / f"{name}.json", "--output", warped, "--background", "#0000ff"]
        )
        np.testing.assert_array_equal(frame, read_image(warped))
    # What the warp leaves transparent (outside the moved cage) is blue, and black in the GIF.
    uncovered = read_image(animation / "last.png")[..., 3] == 0
    assert uncovered.sum() > 100
    assert (frames[-1][uncovered] == [0, 0, 255, 255]).all()
    gif = animation / "black.gif"
    argv = ["animate", animation / "two.json", "--output", gif, "--fps", "2", "--background", "black"]
    assert run_main(argv, capfd)[0] == 0
    from PIL import Image, ImageSequence

    with Image.open(gif) as opened:
        last = [np.asarray(frame.convert("RGB")) for frame in ImageSequence.Iterator(opened)][-1]
    assert np.abs(last[uncovered].astype(int)).max() <= 8  # black, within the GIF's palette


def test_size_and_a_grown_canvas_keep_one_frame_size(animation, capfd):
    output = animation / "grown"
    away = np.asarray(CAGE) + [60.0, 0.0]  # leaves the picture on the right
    (animation / "away.json").write_text(json.dumps(session(CAGE, [(0.0, CAGE), (1.0, away)])))
    argv = ["animate", animation / "away.json", "--output", f"{output}/", "--fps", "4", "--canvas", "grow"]
    assert run_main(argv, capfd)[0] == 0
    sizes = {read_image(path).shape for path in output.iterdir()}
    x0, y0, x1, y1 = output_region((160, 120), away, "grow")  # the last target reaches farthest
    assert sizes == {(120, int(x1 - x0), 4)} and x1 > 190  # one frame size holds every target
    argv = ["animate", animation / "two.json", "--output", animation / "small.mp4", "--size", "81x61"]
    assert run_main(argv, capfd)[0] == 0  # odd sizes are padded for the codec
    video = cv2.VideoCapture(str(animation / "small.mp4"))
    assert (video.get(cv2.CAP_PROP_FRAME_WIDTH), video.get(cv2.CAP_PROP_FRAME_HEIGHT)) == (82, 62)


BAD = {
    "no keyframes": (lambda d: session(CAGE), "out.mp4", r'has no "keyframes"'),
    "wrong count": (
        lambda d: session(CAGE, [(0.0, CAGE), (1.0, CAGE[:-1])]),
        "out.mp4",
        r"keyframes\[1\]: target has 7 control points but cage has 8",
    ),
    "same time": (lambda d: session(CAGE, [(1, CAGE), (1, CAGE)]), "out.gif", r"two keyframes at 1 s"),
    "bad time": (lambda d: session(CAGE, [("soon", CAGE)]), "out.gif", r"time must be a number of seconds"),
    "bad interpolation": (
        lambda d: session(CAGE, [(0, CAGE)], interpolation="cubic"),
        "frames/",
        r'"interpolation" must be one of catmull-rom, linear',
    ),
    "bad extension": (lambda d: session(CAGE, [(0, CAGE)]), "out.avi", r"must end in .mp4 or .gif"),
    "missing folder": (lambda d: session(CAGE, [(0, CAGE)]), "nowhere/out.mp4", r"does not exist"),
    "foreign files": (lambda d: session(CAGE, [(0, CAGE)]), "busy/", r"holds other files than frame_NNNNN"),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, capfd, case):
    make, output, pattern = BAD[case]
    write_png(tmp_path / "picture.png", picture())
    (tmp_path / "busy").mkdir()
    (tmp_path / "busy" / "notes.txt").write_text("mine")
    (tmp_path / "s.json").write_text(json.dumps(make(tmp_path)))
    before = sorted(p.name for p in tmp_path.rglob("*"))
    code, out, err = run_main(["animate", tmp_path / "s.json", "--output", f"{tmp_path}/{output}"], capfd)
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and re.search(pattern, err), err
    assert sorted(p.name for p in tmp_path.rglob("*")) == before


@pytest.mark.parametrize(
    ("output", "stop"),
    [
        ("long.mp4", signal.SIGINT),
        ("long/", signal.SIGINT),
        ("long.mp4", signal.SIGKILL),
        ("long/", signal.SIGKILL),
    ],
)
def test_ctrl_c_leaves_no_output_and_no_temporary(tmp_path, output, stop, capfd):
    """Ctrl+C cleans up at once; after kill -9 the next run to the same output removes the leftovers."""
    write_png(tmp_path / "picture.png", picture())
    moved = transformed(CAGE)
    (tmp_path / "s.json").write_text(json.dumps(session(CAGE, [(0, CAGE), (600, moved)])))
    # `python -m app animate` in a process of its own, forked from the warm server
    # (`support.warm_start`), where SIGINT raises KeyboardInterrupt as from a terminal.
    arguments = ["animate", str(tmp_path / "s.json"), "--output", f"{tmp_path}/{output}"]
    process = warm_start.start(arguments, dict(os.environ), ROOT)
    deadline = time.monotonic() + 120
    while not any(p.name.startswith(".long") for p in tmp_path.iterdir()):  # frames are being written
        assert process.poll() is None and time.monotonic() < deadline, process.communicate()
        time.sleep(0.05)
    time.sleep(0.3)
    process.send_signal(stop)
    _, err = process.communicate(timeout=60)
    if stop == signal.SIGINT:
        assert process.returncode == 130 and err.strip().splitlines()[-1] == "interrupted"
        assert sorted(p.name for p in tmp_path.iterdir()) == ["picture.png", "s.json"]
        return
    assert process.returncode == -signal.SIGKILL
    assert any(p.name.startswith(".long") for p in tmp_path.iterdir())  # what kill -9 leaves
    (tmp_path / "s.json").write_text(json.dumps(session(CAGE, [(0, CAGE), (0.1, moved)])))
    code, _, err = run_main(["animate", tmp_path / "s.json", "--output", f"{tmp_path}/{output}"], capfd)
    assert code == 0, err
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "long" + output[4:].rstrip("/"),
        "picture.png",
        "s.json",
    ]


def gif_delays(count: int, fps: float) -> list[int]:
    return [gif_delay(index, fps) for index in range(count)]


def test_gif_delays_carry_the_rounding_so_the_animation_lasts_its_true_time():
    delays = gif_delays(220, 30)
    assert sum(delays) == 7330 and set(delays) == {30, 40}  # 220 frames at 30 fps: 7.33 s, not 6.6 s
    assert all(abs(sum(delays[:k]) - 1000 * k / 30) <= 5 for k in range(221))  # never off by half a step
    assert gif_delays(11, 10) == [100] * 11
    assert gif_delays(5, 100) == [20] * 5  # GIF viewers show shorter delays as 100 ms


def test_a_gif_at_30_fps_lasts_as_long_as_its_frames(tmp_path):
    from PIL import Image, ImageSequence

    writer = GifWriter(tmp_path / "out.gif", (8, 6), 30.0)
    rng = np.random.default_rng(3)
    for _ in range(22):
        writer.add(np.dstack([rng.integers(0, 256, (6, 8, 3)), np.full((6, 8), 255)]).astype(np.uint8))
    writer.finish()
    with Image.open(tmp_path / "out.gif") as gif:
        durations = [frame.info["duration"] for frame in ImageSequence.Iterator(gif)]
    assert len(durations) == 22 and sum(durations) == 730


def test_a_fold_free_session_animates_fold_free_frames(tmp_path, capfd):
    """``"fold_free": true`` in a session: animate draws each frame as `warp` does for it, fold-free."""
    write_png(tmp_path / "picture.png", picture())
    folding = np.array(CAGE, dtype=np.float64)
    folding[1] = [80.0, 80.0]  # pulled down across the cage: the plain harmonic map folds
    fold_free = {"kernel": "poisson", "fold_free": True}
    (tmp_path / "two.json").write_text(json.dumps(session(CAGE, [(0.0, CAGE), (1.0, folding)], **fold_free)))
    (tmp_path / "last.json").write_text(json.dumps(session(folding, **fold_free)))
    (tmp_path / "plain.json").write_text(json.dumps(session(folding, kernel="poisson")))
    for name in ("last", "plain"):
        main_ok(["warp", "--session", tmp_path / f"{name}.json", "--output", tmp_path / f"{name}.png"])
    code, _, err = run_main(
        ["animate", tmp_path / "two.json", "--output", f"{tmp_path / 'frames'}/", "--fps", "2"], capfd
    )
    assert code == 0, err
    last = read_image(tmp_path / "frames" / "frame_00002.png")
    np.testing.assert_array_equal(last, read_image(tmp_path / "last.png"))
    assert not np.array_equal(last, read_image(tmp_path / "plain.png"))


def test_a_session_with_a_bad_fold_free_value_is_refused(tmp_path, capfd):
    write_png(tmp_path / "picture.png", picture())
    (tmp_path / "bad.json").write_text(json.dumps(session(CAGE, [(0.0, CAGE)], fold_free="yes")))
    code, _, err = run_main(["animate", tmp_path / "bad.json", "--output", f"{tmp_path / 'frames'}/"], capfd)
    assert code == 2 and err.count("\n") == 1 and '"fold_free" must be true or false' in err
