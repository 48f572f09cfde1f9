"""``warp --pins``: pins in the picture solved into the target, ``--max-distortion``, ``--report``, a
session's pins, and bad input (one line, nothing written)."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from support.commands import CAGE, files, private_cache, run_main, warp_argv  # noqa: F401 (fixtures)

from app.io.files import read_image

PINS = [[50.0, 50.0], [110.0, 50.0], [80.0, 80.0], [60.0, 75.0]]
MOVED = [[48.0, 52.0], [118.0, 40.0], [82.0, 86.0], [60.0, 75.0]]


def pins_file(directory, pins, moved, name="pins.json"):
    path = directory / name
    path.write_text(json.dumps({"pins": pins, "moved": moved}))
    return path


def pinned_argv(directory, pins=PINS, moved=MOVED, *extra):
    return [*warp_argv(directory, **{"--target": None, "--pins": pins_file(directory, pins, moved)}), *extra]


def test_two_pins_warp_like_the_similarity_that_places_them(files, capfd):
    turn = np.array([[0.95, -0.2], [0.2, 0.95]])
    shift = np.array([6.0, -4.0])
    moved = (np.array(PINS[:2]) @ turn.T + shift).tolist()
    code, out, _ = run_main([*pinned_argv(files, PINS[:2], moved), "--report"], capfd)
    assert code == 0
    assert re.search(r"pin 0: lands \S+ px from where it was moved", out)
    assert "proven sigma1/sigma2 <= 1 and det J > 0" in out
    pinned = read_image(files / "out.png")
    target = (np.array(CAGE, dtype=float) @ turn.T + shift).tolist()
    (files / "similar.json").write_text(json.dumps({"control_points": target}))
    argv = warp_argv(files, **{"--target": files / "similar.json", "--output": files / "similar.png"})
    assert run_main(argv, capfd)[0] == 0
    difference = np.abs(pinned.astype(int) - read_image(files / "similar.png").astype(int))
    assert difference.max() <= 1


def test_four_pins_within_a_bound_report_each_pin_and_the_proven_bound(files, capfd):
    code, out, _ = run_main([*pinned_argv(files), "--max-distortion", "1.5", "--report"], capfd)
    assert code == 0 and (files / "out.png").exists()
    errors = [float(x) for x in re.findall(r"pin \d: lands (\S+) px from where it was moved", out)]
    assert len(errors) == 4
    proven = float(
        re.search(r"asked sigma1/sigma2 <= 1\.5; proven sigma1/sigma2 <= (\S+) and det J > 0", out)[1]
    )
    assert 1.0 <= proven <= 1.5 + 1e-5
    # One truth: the report's certificate is the pins' solve's, whose k gives that bound.
    k = float(re.search(r"certificate: fold-free, proven \(σ₂ ≥ \S+, k ≤ ([\d.]+);", out)[1])
    assert (1 + k) / (1 - k) == pytest.approx(proven, rel=5e-3)


def test_a_sessions_pins_make_its_target(files, capfd):
    session = json.loads((files / "session.json").read_text())
    session.update(kernel="poisson", pins=[{"at": a, "to": b} for a, b in zip(PINS, MOVED, strict=True)])
    session["max_distortion"] = 1.5
    (files / "pinned.json").write_text(json.dumps(session))
    argv = ["warp", "--session", files / "pinned.json", "--output", files / "s.png", "--report"]
    code, out, _ = run_main(argv, capfd)
    assert code == 0 and (files / "s.png").exists()
    errors = [float(x) for x in re.findall(r"pin \d: lands (\S+) px from where it was moved", out)]
    assert len(errors) == 4 and max(errors) < 5.0
    proven = re.search(r"asked sigma1/sigma2 <= 1\.5; proven sigma1/sigma2 <= (\S+) and det J > 0", out)
    assert proven and float(proven[1]) <= 1.5 + 1e-5, out
    # The session's own target is not what was drawn: the pins moved the pins' points.
    assert run_main(["warp", "--session", files / "session.json", "--output", files / "t.png"], capfd)[0] == 0
    assert (
        np.abs(read_image(files / "s.png").astype(int) - read_image(files / "t.png").astype(int)).max() > 50
    )


BAD = {
    "pin outside": (
        lambda d: pinned_argv(d, [[0.0, 0.0]], [[5.0, 5.0]]),
        r"pins\.json: pin 0 at \(0, 0\) is outside the cage",
    ),
    "two pins at one point": (
        lambda d: pinned_argv(d, [[50.0, 50.0], [50.0, 50.0]], [[50.0, 50.0], [60.0, 60.0]]),
        r"pins\.json: pins 0 and 1 are at one point \(50, 50\)",
    ),
    "not finite": (
        lambda d: pinned_argv(d, [[50.0, 50.0]], [[float("nan"), 0.0]]),
        r'pins\.json: "moved"\[0\]: must be a pair of finite',
    ),
    "K below 1": (
        lambda d: [*pinned_argv(d), "--max-distortion", "0.5"],
        r"--max-distortion: must be a number >= 1",
    ),
    "K not a number": (
        lambda d: [*pinned_argv(d), "--max-distortion", "nan"],
        r"--max-distortion: must be a number >= 1",
    ),
    "pins and target": (
        lambda d: [*warp_argv(d), "--pins", pins_file(d, PINS, MOVED)],
        r"give --target or --pins, not both",
    ),
    "bound without pins": (
        lambda d: [*warp_argv(d), "--max-distortion", "2"],
        r"--max-distortion bounds the pins' warp",
    ),
    "one list short": (
        lambda d: pinned_argv(d, PINS, MOVED[:3]),
        r'pins\.json: 4 "pins" but 3 "moved" points',
    ),
    "another kernel": (
        lambda d: [*pinned_argv(d), "--kernel", "mean-value"],
        r"pins work with the kernels poisson and cauchy-green",
    ),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_pins_are_one_line_and_write_nothing(files, capfd, case):
    make_argv, pattern = BAD[case]
    code, _, err = run_main(make_argv(files), capfd)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, err
    assert re.search(pattern, lines[0]), lines[0]
    assert not (files / "out.png").exists()


def test_a_sessions_bad_bound_is_one_line(files, capfd):
    session = json.loads((files / "session.json").read_text())
    session.update(kernel="poisson", pins=[{"at": PINS[0], "to": MOVED[0]}], max_distortion=0.2)
    (files / "pinned.json").write_text(json.dumps(session))
    code, _, err = run_main(["warp", "--session", files / "pinned.json", "--output", files / "s.png"], capfd)
    assert code == 2 and re.search(r'pinned\.json.*"max_distortion" must be a number >= 1', err.strip()), err
    assert not (files / "s.png").exists()


def test_animate_refuses_a_sessions_bad_pins_like_warp(files, capfd):
    session = json.loads((files / "session.json").read_text())
    keyframes = [{"time": t, "target": session["target"]} for t in (0.0, 0.5)]
    session.update(kernel="poisson", keyframes=keyframes, pins=[{"at": [0.0, 0.0]}])
    (files / "pinned.json").write_text(json.dumps(session))
    code, _, err = run_main(["animate", files / "pinned.json", "--output", files / "a.gif"], capfd)
    assert code == 2 and re.search(r'pinned\.json: pins\[0\]: expected an object with "at" and "to"', err), (
        err
    )
    assert not (files / "a.gif").exists()
