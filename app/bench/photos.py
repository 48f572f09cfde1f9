"""``bench``'s photograph rows: a warp of a 24 and a 100 megapixel PNG and JPEG against reading and
writing it.

Each size runs in a child process of its own: the picture is generated there (a
photograph scaled up, with grain, so that PNG compresses it like a photograph), then
the warp (``--outside original``, the whole command in-process, basis not cached) and
the baseline, `app.io.files.read_image` then `write_image` of the same picture in the same
format, alternate
in the same process; the row shows the medians, the ratio of the warp's time to
1.5 x baseline + 1.5 s (the issue's bound: at most 1) and the warp's peak memory
(the process's high-water mark, measured before any baseline ran).
"""

from __future__ import annotations

import itertools
import json
import os
import sys
import tempfile
from pathlib import Path

#: (width, height) of the rows: 24 and 100 megapixels.
PHOTO_SIZES = ((6000, 4000), (12000, 8400))
#: The formats of the rows, by extension.
PHOTO_FORMATS = ("png", "jpg")
#: The quick smoke test's size, and its animation's (smaller: there the GIF's frames cost most).
QUICK_SIZE = (1200, 800)
QUICK_ANIMATION_SIZE = (600, 400)
#: Runs of the warp and of the baseline in each child.
PHOTO_REPEATS = 2


def photograph(width: int, height: int, grain: bool = True):
    """A picture like a photograph: soft discs drawn small and scaled up, with grain (so that PNG
    compresses it as it would a photograph), seed 5: ndarray (height, width, 3) uint8, BGR."""
    import cv2
    import numpy as np

    rng = np.random.default_rng(5)
    small = np.zeros((240, 360, 3), np.uint8)
    for _ in range(60):
        centre = (int(rng.integers(0, 360)), int(rng.integers(0, 240)))
        colour = tuple(int(c) for c in rng.integers(0, 255, 3))
        cv2.circle(small, centre, int(rng.integers(5, 60)), colour, -1, cv2.LINE_AA)
    image = cv2.resize(small, (width, height), interpolation=cv2.INTER_CUBIC)
    return cv2.add(image, rng.integers(0, 6, image.shape, dtype=np.uint8)) if grain else image


_CHILD = r"""
import json, statistics, sys, time
from pathlib import Path

import cv2
import numpy as np

from app.__main__ import main
from app.bench.photos import photograph, write_starfish_drag
from app.io.files import read_image, write_image

width, height, folder, repeats = int(sys.argv[1]), int(sys.argv[2]), Path(sys.argv[3]), int(sys.argv[4])
kind = sys.argv[5]
image = photograph(width, height)
cv2.imwrite(str(folder / f"photo.{kind}"), image)
del image
write_starfish_drag(folder, width, height)
argv = ["warp", str(folder / f"photo.{kind}"), "--cage", str(folder / "cage.json"), "--target",
        str(folder / "target.json"), "--output", str(folder / f"out.{kind}"), "--outside", "original"]

def high_water():
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1])

def baseline():
    start = time.perf_counter()
    write_image(folder / f"copy.{kind}", read_image(folder / f"photo.{kind}"))
    return time.perf_counter() - start

def warp():
    start = time.perf_counter()
    if main(argv) != 0:
        raise SystemExit("the warp failed")
    return time.perf_counter() - start

before = high_water()
warps, baselines = [warp()], []
peak = high_water()
for _ in range(repeats):
    baselines.append(baseline())
    if len(warps) < repeats:
        warps.append(warp())
print(json.dumps({"warp": statistics.median(warps), "baseline": statistics.median(baselines),
                  "peak": peak, "before": before}))
"""


def write_starfish_drag(folder: Path, width: int, height: int) -> None:
    """Write ``cage.json`` (the starfish, centred on a `width` x `height` image) and ``target.json``
    (two of its arms dragged) into `folder`: the warp the bench times on generated pictures."""
    import numpy as np

    from core import examples

    cage = examples.starfish() * (0.45 * height) + np.array([width / 2, height / 2])
    target = cage.copy()
    target[0] += (0.1 * height, 0.05 * height)
    target[4] -= (0.05 * height, 0.1 * height)
    (folder / "cage.json").write_text(json.dumps({"control_points": cage.tolist()}))
    (folder / "target.json").write_text(json.dumps({"control_points": target.tolist()}))


def photo_rows(sizes, run_child, repeats: int = PHOTO_REPEATS, kinds=PHOTO_FORMATS) -> None:
    """Print one row per (width, height) of `sizes` and format of `kinds`; `run_child` is
    `app.bench.table.run_child`."""
    for (width, height), kind in itertools.product(sizes, kinds):
        with tempfile.TemporaryDirectory() as folder:
            environment = dict(os.environ, TRANSFINITE_CACHE_DIR=str(Path(folder) / "cache"))
            command = [sys.executable, "-c", _CHILD, str(width), str(height), folder, str(repeats), kind]
            result = run_child(command, f"the {width}x{height} {kind} photograph warp", env=environment)
        row = json.loads(result.stdout.strip().splitlines()[-1])
        bound = 1.5 * row["baseline"] + 1.5
        print(
            f"photograph {width}x{height} ({width * height / 1e6:.0f} MP) {kind.upper()} "
            "warp --outside original: "
            f"{row['warp']:.2f} s; read + write {row['baseline']:.2f} s; "
            f"warp / (1.5 x (read + write) + 1.5 s) = {row['warp'] / bound:.2f}; "
            f"warp peak memory {row['peak'] / 2**20:.2f} GiB"
        )


#: (width, height) and seconds at 30 fps of the animation row's session.
ANIMATION_SIZE, ANIMATION_SECONDS = (1600, 1200), 2.0
#: Turns of the animation row: PNG frames then GIF, each turn, in one process.
ANIMATION_REPEATS = 3

_ANIMATION_CHILD = r"""
import json, statistics, sys, time
from pathlib import Path

import cv2
import numpy as np

from app.__main__ import main
from app.bench.photos import photograph, write_starfish_drag

width, height, seconds = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
folder, repeats = Path(sys.argv[4]), int(sys.argv[5])
cv2.imwrite(str(folder / "photo.png"), photograph(width, height, grain=False))
write_starfish_drag(folder, width, height)
cage, target = (np.array(json.loads((folder / f"{name}.json").read_text())["control_points"])
                for name in ("cage", "target"))
keyframes = [{"time": t, "target": {"control_points": p.tolist()}}
             for t, p in ((0.0, cage), (seconds, target))]
session = {"image": "photo.png", "cage": {"control_points": cage.tolist()}, "kernel": "poisson",
           "target": {"control_points": target.tolist()}, "view": {"scale": 1.0, "offset": [0, 0]},
           "keyframes": keyframes, "outside": "original"}
(folder / "session.json").write_text(json.dumps(session))
# The basis computed and cached first: the row times the frames.
main(["animate", str(folder / "session.json"), "--output", str(folder / "warm.gif"), "--fps", "1"])
results = {"frames/": ([], []), "out.gif": ([], [])}
for _ in range(repeats):
    for output, (times, peaks) in results.items():
        with open("/proc/self/clear_refs", "w") as stream:  # the high-water mark starts again here
            stream.write("5")
        start = time.perf_counter()
        argv = ["animate", str(folder / "session.json"), "--output", str(folder / output), "--fps", "30"]
        if main(argv) != 0:
            raise SystemExit("animate failed")
        times.append(time.perf_counter() - start)
        status = open("/proc/self/status").read().splitlines()
        peaks.append(next(int(line.split()[1]) for line in status if line.startswith("VmHWM:")))
print(json.dumps({output: {"seconds": statistics.median(times), "peak": max(peaks)}
                  for output, (times, peaks) in results.items()}))
"""


def animation_row(
    run_child, size=ANIMATION_SIZE, seconds: float = ANIMATION_SECONDS, repeats: int = ANIMATION_REPEATS
) -> None:
    """Print the row of ``animate`` to GIF of a `size` session of `seconds` at 30 fps against the same
    frames written as PNGs: in turns in one child process (the machine's load falls on both alike),
    the medians of `repeats` turns, and each one's peak memory (the process's high-water mark, reset
    before each run)."""
    with tempfile.TemporaryDirectory() as folder:
        environment = dict(os.environ, TRANSFINITE_CACHE_DIR=str(Path(folder) / "cache"))
        arguments = [*map(str, size), str(seconds), folder, str(repeats)]
        command = [sys.executable, "-c", _ANIMATION_CHILD, *arguments]
        result = run_child(command, "the GIF and PNG frames animation", env=environment)
    results = json.loads(result.stdout.strip().splitlines()[-1])
    gif, frames = results["out.gif"], results["frames/"]
    print(
        f"animate {size[0]}x{size[1]}, {seconds:g} s at 30 fps, --outside original "
        f"(median of {repeats}, in turns): "
        f"GIF {gif['seconds']:.2f} s, "
        f"PNG frames {frames['seconds']:.2f} s, GIF / PNG frames = {gif['seconds'] / frames['seconds']:.2f}; "
        f"peak memory: GIF {gif['peak'] / 2**20:.2f} GiB, PNG frames {frames['peak'] / 2**20:.2f} GiB"
    )
