"""Helpers of the command-line tests: a picture, a cage and its affine image, the `files` fixture
that writes them, running `app.__main__.main` in-process, a warp's arguments."""

from __future__ import annotations

import json

import numpy as np
import pytest

from app.__main__ import main
from app.io.files import write_png

# A rounded, slightly non-convex cage well inside the picture (image pixels).
WIDTH, HEIGHT = 160, 120
CAGE = [[30, 20], [80, 30], [130, 18], [140, 60], [128, 100], [80, 92], [28, 102], [20, 60]]


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
