"""Bundled demos: procedurally drawn 640 x 480 images, their cages and scripted drags.

Every demo image is drawn here with numpy and OpenCV, so the pictures carry no
third-party rights (see ``assets/README.md``).  They show what transfinite
coordinates on B-spline cages are good at: non-convex shapes with limbs (the
paper's starfish of Fig. 11), a figure with arms and legs, and a patterned
horseshoe whose checkerboard makes every distortion visible and whose two ends
can be pulled together (where mean value coordinates fold over).

``assets/NAME.png``, ``assets/NAME.cage.json``, ``assets/NAME.script.json`` and
``assets/NAME.session.json`` (a session whose keyframes are the script's moves,
`script_keyframes`, for ``demo NAME --play`` and ``animate``) are written by
``python -m app.viewer.demos`` (``--output DIR`` elsewhere) and shipped in the
package (`app.io.bundled`); when they cannot be found as files, the demo is drawn
again into the cache directory, so every demo is also embedded in the code.

`SCRIPT_FORMAT` says what a script file holds; `ScriptPlayer` turns its moves
into the same input events the window produces.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from app.io.bundled import bundled_directory
from app.io.files import (
    InputError,
    finite_number,
    read_cage,
    read_json,
    write_cage,
    write_json,
    write_png,
)
from app.io.session import Animation, KernelChoice, Session, read_session, write_session
from app.viewer.editing import curve_points, default_max_edge
from app.warp.keyframes import DEFAULT_INTERPOLATION, Keyframe
from core import DEFAULT_KERNEL

SIZE = (640, 480)
DEFAULT_DEMO = "starfish"

#: The format of a demo script, as the help of ``demo`` and ``assets/README.md`` give it (word for word).
SCRIPT_FORMAT = (
    'A script is JSON {"moves": [{"at": s, "duration": d, "point": i, "to": [x, y]}, ...]}: '
    "at s seconds from the start of the replay, press the mouse on target control point i, "
    "drag it to the image point (x, y) (pixels, origin top-left) over d seconds (default 1), "
    'and release. Moves run one after another, like one hand on the mouse. A move with "fold_free": '
    "true or false switches fold-free on or off (B) before it starts."
)


def _asset_directory() -> Path | None:
    """The bundled ``assets`` folder, or None if it is not a folder on the file system."""
    directory = bundled_directory("assets")
    return directory if isinstance(directory, Path) and directory.is_dir() else None


#: The shipped demo files (None: draw every demo into the cache directory instead).
ASSETS = _asset_directory()


@dataclass(frozen=True)
class Demo:
    """One bundled demo: how to draw it and what it shows."""

    name: str
    title: str
    description: str
    draw: Callable[[], tuple[np.ndarray, np.ndarray, list[dict]]]


# -- drawing helpers -----------------------------------------------------------------


def _noise(shape, scale: float, seed: int) -> np.ndarray:
    """Smooth value noise in [-1, 1] of the given (H, W), features about `scale` pixels."""
    rng = np.random.default_rng(seed)
    height, width = shape
    coarse = rng.uniform(-1, 1, (int(height / scale) + 3, int(width / scale) + 3)).astype(np.float32)
    big = cv2.resize(coarse, (coarse.shape[1] * int(scale), coarse.shape[0] * int(scale)), cv2.INTER_CUBIC)
    return np.clip(big[:height, :width], -1, 1)


def _rgba(rgb: np.ndarray) -> np.ndarray:
    rgb = np.clip(rgb, 0, 255).astype(np.uint8)
    return np.dstack([rgb, np.full(rgb.shape[:2], 255, np.uint8)])


def _fill(mask: np.ndarray, outline: np.ndarray) -> None:
    cv2.fillPoly(mask, [np.round(outline * 16).astype(np.int32)], 255, lineType=cv2.LINE_AA, shift=4)


def _enclosing_cage(mask: np.ndarray, points: int, margin: int) -> np.ndarray:
    """A cage fitted (app.fit.subject) around the mask grown by `margin` pixels."""
    from app.fit.subject import fit_cage

    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * margin + 1, 2 * margin + 1))
    grown = cv2.dilate((mask > 127).astype(np.uint8) * 255, kernel)
    image = np.dstack([np.zeros(mask.shape + (3,), np.uint8), grown])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return np.round(fit_cage(image, points), 2)


def _nearest(cage: np.ndarray, point) -> int:
    return int(np.argmin(np.hypot(*(cage - np.asarray(point, dtype=np.float64)).T)))


def _move(at: float, duration: float, point: int, to) -> dict:
    return {"at": at, "duration": duration, "point": int(point), "to": [round(float(v), 2) for v in to]}


# -- the demos -------------------------------------------------------------------------


def _star_points(scale: float) -> np.ndarray:
    """Control points of a five-armed starfish (4 per arm), image pixels, one arm up."""
    centre = np.array([320.0, 250.0])
    rows = []
    for arm in range(5):
        base = -math.pi / 2 + arm * 2 * math.pi / 5
        step = 2 * math.pi / 5
        for fraction, radius in ((0.0, 215.0), (0.2, 100.0), (0.5, 72.0), (0.8, 100.0)):
            angle = base + fraction * step
            rows.append(centre + scale * radius * np.array([math.cos(angle), math.sin(angle)]))
    return np.array(rows)


def draw_starfish() -> tuple[np.ndarray, np.ndarray, list[dict]]:
    """An orange starfish with tubercles on sand; the cage wraps it like the paper's Fig. 11."""
    width, height = SIZE
    y, x = np.mgrid[0:height, 0:width].astype(np.float32)
    sand = np.stack([214 + 0 * x, 196 + 0 * x, 160 + 0 * x], axis=-1)
    sand += 14 * _noise((height, width), 6, 1)[..., None] + 8 * _noise((height, width), 2, 2)[..., None]
    outline = curve_points(_star_points(0.93), 32)
    mask = np.zeros((height, width), np.uint8)
    _fill(mask, outline)
    inside = mask.astype(np.float32)[..., None] / 255
    centre = np.array([320.0, 250.0])
    radius = np.hypot(x - centre[0], y - centre[1])
    body = np.stack([235 - 0.25 * radius, 120 - 0.18 * radius, 45 + 0 * radius], axis=-1)
    body += 10 * _noise((height, width), 4, 3)[..., None]
    picture = sand * (1 - inside) + body * inside
    # A ridge of pale tubercles along every arm and a scatter of small ones.
    canvas = picture.astype(np.float32)
    for arm in range(5):
        angle = -math.pi / 2 + arm * 2 * math.pi / 5
        direction = np.array([math.cos(angle), math.sin(angle)])
        for step in range(3, 19):
            r = 10.0 * step
            size = max(2, int(9 - 0.35 * step))
            for side in (-1, 1) if step % 2 else (0,):
                p = centre + r * direction + side * 9 * np.array([-direction[1], direction[0]])
                cv2.circle(canvas, tuple(int(v) for v in p), size, (250, 220, 170), -1, cv2.LINE_AA)
    rng = np.random.default_rng(7)
    for p in rng.uniform([0, 0], [width, height], size=(900, 2)):
        if mask[int(p[1]), int(p[0])] > 200:
            cv2.circle(
                canvas, (int(p[0]), int(p[1])), int(rng.integers(1, 4)), (160, 60, 30), -1, cv2.LINE_AA
            )
    cv2.circle(canvas, (320, 250), 14, (200, 70, 110), -1, cv2.LINE_AA)
    cv2.polylines(canvas, [np.round(outline).astype(np.int32)], True, (120, 45, 20), 2, cv2.LINE_AA)
    picture = canvas * inside + picture * (1 - inside)
    cage = np.round(_star_points(1.0), 2)
    tips = [4 * arm for arm in range(5)]
    moves = [
        _move(0.5, 1.2, tips[1], cage[tips[1]] + [40, -70]),
        _move(2.0, 1.2, tips[4], cage[tips[4]] + [-40, -70]),
        _move(3.5, 1.0, tips[0], cage[tips[0]] + [60, 10]),
        _move(4.8, 1.0, tips[2], cage[tips[2]] + [-30, 40]),
    ]
    return _rgba(picture), cage, moves


def draw_character() -> tuple[np.ndarray, np.ndarray, list[dict]]:
    """A gingerbread figure with arms and legs, icing, eyes and buttons."""
    width, height = SIZE
    y, x = np.mgrid[0:height, 0:width].astype(np.float32)
    background = np.stack([235 + 0 * x, 232 + 0 * x, 222 + 0 * x], axis=-1)
    stripes = ((x + y) // 24 % 2).astype(np.float32)[..., None]
    background -= 10 * stripes
    mask = np.zeros((height, width), np.uint8)
    limbs = [
        ((280, 200), (160, 150)),
        ((360, 200), (480, 150)),
        ((295, 320), (235, 430)),
        ((345, 320), (405, 430)),
    ]
    cv2.circle(mask, (320, 115), 62, 255, -1, cv2.LINE_AA)
    cv2.ellipse(mask, (320, 255), (78, 100), 0, 0, 360, 255, -1, cv2.LINE_AA)
    for start, end in limbs:
        cv2.line(mask, start, end, 255, 58, cv2.LINE_AA)
        cv2.circle(mask, end, 29, 255, -1, cv2.LINE_AA)
    inside = mask.astype(np.float32)[..., None] / 255
    dough = np.stack([178 + 0 * x, 108 + 0 * x, 58 + 0 * x], axis=-1)
    dough += 12 * _noise((height, width), 5, 11)[..., None] - 0.04 * np.abs(x - 320)[..., None]
    canvas = (background * (1 - inside) + dough * inside).astype(np.float32)
    icing = (250, 250, 245)
    for start, end in limbs:
        direction = np.subtract(end, start) / np.hypot(*np.subtract(end, start))
        normal = np.array([-direction[1], direction[0]])
        for offset in (-34, -22):
            centre = np.asarray(end) + offset * direction
            wave = [centre + s * normal + 4 * math.sin(s / 4) * direction for s in np.linspace(-24, 24, 25)]
            cv2.polylines(canvas, [np.round(wave).astype(np.int32)], False, icing, 4, cv2.LINE_AA)
    for eye in ((297, 100), (343, 100)):
        cv2.circle(canvas, eye, 11, icing, -1, cv2.LINE_AA)
        cv2.circle(canvas, eye, 5, (40, 25, 20), -1, cv2.LINE_AA)
    cv2.ellipse(canvas, (320, 128), (26, 18), 0, 20, 160, icing, 4, cv2.LINE_AA)
    for button, colour in (
        ((320, 210), (220, 40, 50)),
        ((320, 255), (40, 160, 70)),
        ((320, 300), (40, 90, 210)),
    ):
        cv2.circle(canvas, button, 12, colour, -1, cv2.LINE_AA)
        cv2.circle(canvas, button, 12, icing, 2, cv2.LINE_AA)
    picture = canvas * inside + background * (1 - inside)
    cage = _enclosing_cage(mask, 26, 10)
    left_hand, right_hand = _nearest(cage, (140, 140)), _nearest(cage, (500, 140))
    left_foot, right_foot = _nearest(cage, (225, 455)), _nearest(cage, (415, 455))
    moves = [
        _move(0.5, 1.0, left_hand, cage[left_hand] + [10, -110]),
        _move(1.8, 1.0, right_hand, cage[right_hand] + [-10, -110]),
        _move(3.1, 1.0, right_foot, cage[right_foot] + [70, -60]),
        _move(4.4, 1.0, left_foot, cage[left_foot] + [-30, 0]),
    ]
    return _rgba(picture), cage, moves


def draw_pattern() -> tuple[np.ndarray, np.ndarray, list[dict]]:
    """A horseshoe with a checkerboard, rings and a diagonal band: every distortion shows."""
    width, height = SIZE
    y, x = np.mgrid[0:height, 0:width].astype(np.float32)
    checker = ((x // 20 + y // 20) % 2).astype(np.float32)[..., None]
    light, dark = np.array([245, 240, 225]), np.array([40, 70, 120])
    picture = light * (1 - checker) + dark * checker
    rings = (np.hypot(x - 320, y - 240) // 30 % 2 == 0)[..., None]
    band = (np.abs(x - y - 80) < 18)[..., None]
    picture = np.where(rings & (checker > 0.5), np.array([190, 60, 60]), picture)
    picture = np.where(band, np.array([250, 190, 40]), picture)
    mask = np.zeros((height, width), np.uint8)
    cv2.ellipse(mask, (320, 240), (215, 200), 0, 35, 325, 255, -1, cv2.LINE_AA)
    cv2.ellipse(mask, (320, 240), (105, 95), 0, 0, 360, 0, -1, cv2.LINE_AA)
    cv2.fillPoly(mask, [np.array([[320, 240], [600, 40], [600, 440]], np.int32)], 0, cv2.LINE_AA)
    cv2.ellipse(mask, (320, 240), (215, 200), 0, 35, 325, 255, 0)
    # Round the two ends of the horseshoe.
    for angle in (35, 325):
        centre = (320 + 160 * math.cos(math.radians(angle)), 240 + 148 * math.sin(math.radians(angle)))
        cv2.circle(mask, tuple(int(v) for v in centre), 52, 255, -1, cv2.LINE_AA)
    inside = mask.astype(np.float32)[..., None] / 255
    picture = picture * inside + np.array([255, 255, 255]) * (1 - inside)
    cage = _enclosing_cage(mask, 24, 8)
    # Close the gap: every control point around each rounded end moves towards the other end.
    moves, at = [], 0.5
    for centre, shift in (((451, 155), 40.0), ((451, 325), -40.0)):
        for index in np.flatnonzero(np.hypot(*(cage - centre).T) < 85):
            moves.append(_move(at, 0.6, index, cage[index] + [0.0, shift]))
            at += 0.7
    return _rgba(picture), cage, moves


DEMOS = {
    demo.name: demo
    for demo in (
        Demo("starfish", "Starfish", "five limbs, the paper's Fig. 11", draw_starfish),
        Demo("character", "Gingerbread figure", "arms and legs", draw_character),
        Demo("pattern", "Patterned horseshoe", "a checkerboard shows every distortion", draw_pattern),
    )
}


# -- files -------------------------------------------------------------------------------


@dataclass(frozen=True)
class DemoFiles:
    """Where a demo's files are."""

    name: str
    image: Path
    cage: Path
    script: Path
    session: Path


def demo_files(name: str = DEFAULT_DEMO) -> DemoFiles:
    """The files of demo `name`: the shipped ones when present, else drawn into the cache directory.

    Raises
    ------
    InputError
        For an unknown name (the message lists the demos).
    """
    if name not in DEMOS:
        raise InputError(f"unknown demo {name!r}; choose one of {', '.join(DEMOS)}")
    for directory in (ASSETS, _cache_directory()):
        if directory is None:
            continue
        files = _files_in(directory, name)
        if all(path.is_file() for path in (files.image, files.cage, files.script, files.session)):
            return files
    write_demo(name, _cache_directory())
    return _files_in(_cache_directory(), name)


def is_demo_file(path: str | os.PathLike) -> bool:
    """Whether `path` is one of the bundled demos' files (shipped, or drawn into the cache)."""
    folder = Path(path).resolve().parent
    return any(
        directory is not None and folder == Path(directory).resolve()
        for directory in (ASSETS, _cache_directory())
    )


def write_demo(name: str, directory: Path) -> DemoFiles:
    """Draw demo `name` and write its image, cage, script and keyframed session into `directory`."""
    image, cage, moves = DEMOS[name].draw()
    directory.mkdir(parents=True, exist_ok=True)
    files = _files_in(directory, name)
    write_png(files.image, image)
    write_cage(files.cage, cage)
    write_json(files.script, {"demo": name, "moves": moves})
    cage = read_cage(files.cage)  # rounded as in the file
    keyframes = script_keyframes(cage, read_script(files.script, len(cage)))
    # The session shows the script's boldest pose, so that `warp --session` (and any kernel chosen
    # for it) shows a deformation, with the default kernel, which nothing needs compiling for.
    boldest = max(keyframes, key=lambda keyframe: np.abs(keyframe.target - cage).max())
    session = Session(
        files.image,
        cage,
        boldest.target,
        KernelChoice(DEFAULT_KERNEL),
        max_edge=default_max_edge(cage),  # the viewer's mesh: animate shows what it plays
        animation=Animation(keyframes, DEFAULT_INTERPOLATION),
    )
    write_session(files.session, session)
    return files


def demo_keyframes(files: DemoFiles) -> tuple[Keyframe, ...]:
    """The keyframes of a demo's session file (`InputError` if it cannot be read)."""
    return read_session(files.session).animation.keyframes


#: Seconds from the last move of a script back to the start, so that the animation loops.
RETURN_SECONDS = 1.5


def script_keyframes(cage: np.ndarray, moves: list[Move]) -> tuple[Keyframe, ...]:
    """Keyframes of a script: the cage at 0 s, the pose after each move when it ends, and back.

    Parameters
    ----------
    cage : ndarray of shape (n, 2)
        Source control points; the script's moves start from them (target = cage).
    moves : list of Move

    Returns
    -------
    tuple of Keyframe
        ``len(moves) + 2`` keyframes: the rest pose at 0 s, one per move at its
        end time, and the rest pose again `RETURN_SECONDS` after the last.
    """
    pose = np.array(cage, dtype=np.float64)
    keyframes = [Keyframe(0.0, pose)]
    for move in moves:
        pose = pose.copy()
        pose[move.point] = move.to
        keyframes.append(Keyframe(move.at + move.duration, pose))
    keyframes.append(Keyframe(keyframes[-1].time + RETURN_SECONDS, cage))
    return tuple(keyframes)


def _files_in(directory: Path, name: str) -> DemoFiles:
    return DemoFiles(
        name,
        directory / f"{name}.png",
        directory / f"{name}.cage.json",
        directory / f"{name}.script.json",
        directory / f"{name}.session.json",
    )


def _cache_directory() -> Path:
    from core import cache_directory

    return cache_directory() / "demos"


# -- scripts -------------------------------------------------------------------------------


@dataclass(frozen=True)
class Move:
    """Drag target control point `point` to image point `to` from time `at` for `duration` seconds,
    with fold-free switched on or off first (`fold_free`, None: as it is)."""

    at: float
    duration: float
    point: int
    to: tuple[float, float]
    fold_free: bool | None = None


def read_script(path: str | Path, control_points: int | None = None) -> list[Move]:
    """Read and validate a script file; `InputError` naming the file and the bad move.

    Parameters
    ----------
    path : path-like
    control_points : int, optional
        The cage's number of points; point indices are checked against it.
    """
    value = read_json(path)
    moves = value.get("moves") if isinstance(value, dict) else value
    if not isinstance(moves, list):
        raise InputError(f'{path}: expected {{"moves": [...]}} or a list of moves')
    result = []
    end = 0.0
    for number, item in enumerate(moves):
        where = f"{path}: moves[{number}]"
        if not isinstance(item, dict) or not {"at", "point", "to"} <= set(item):
            raise InputError(f'{where}: expected an object with "at", "point", "to" (and "duration")')
        at, duration = finite_number(item["at"]), finite_number(item.get("duration", 1.0))
        to = tuple(finite_number(v) for v in item["to"]) if isinstance(item["to"], list) else ()
        point = item["point"]
        if len(to) != 2 or None in (at, duration, *to):
            raise InputError(f"{where}: at, duration and to must be numbers (finite; to a pair [x, y])")
        if (
            not isinstance(point, int)
            or point < 0
            or (control_points is not None and point >= control_points)
        ):
            limit = f" 0..{control_points - 1}" if control_points is not None else ""
            raise InputError(f"{where}: point must be a control point index{limit}, got {point!r}")
        if duration <= 0 or at < end:
            raise InputError(f"{where}: moves must not overlap and need a duration > 0")
        fold_free = item.get("fold_free")
        if fold_free is not None and not isinstance(fold_free, bool):
            raise InputError(f"{where}: fold_free must be true or false, got {fold_free!r}")
        end = at + duration
        result.append(Move(at, duration, point, to, fold_free))
    return result


class ScriptPlayer:
    """Turns script moves into mouse events, like a hand on the mouse.

    Each move becomes a press on the target handle (at its current window
    position), cursor moves along an eased path, and a release, fed to the same
    handler as the window's events.

    Parameters
    ----------
    moves : list of Move
    """

    def __init__(self, moves: list[Move]):
        self.moves = list(moves)
        self._next = 0  # first move not finished
        self._pressed = False
        self._start: np.ndarray | None = None

    @property
    def finished(self) -> bool:
        return self._next >= len(self.moves)

    @property
    def duration(self) -> float:
        return max((m.at + m.duration for m in self.moves), default=0.0)

    def events(self, time: float, handle_position: Callable[[int], np.ndarray], to_window) -> list[tuple]:
        """Events due at script time `time` (seconds).

        Parameters
        ----------
        handle_position : callable
            Image position of target control point i now.
        to_window : callable
            Image point (2,) -> window pixels (2,).

        Returns
        -------
        list of tuple
            ``("press", x, y)``, ``("move", x, y)``, ``("release", x, y)`` in window pixels;
            ``("fold_free", on, None)`` before a move's press that sets the switch.
        """
        events = []
        while not self.finished:
            move = self.moves[self._next]
            if time < move.at:
                break
            if not self._pressed:
                if move.fold_free is not None:
                    events.append(("fold_free", move.fold_free, None))
                self._start = np.asarray(handle_position(move.point), dtype=np.float64)
                events.append(("press", *to_window(self._start)))
                self._pressed = True
            fraction = min(1.0, (time - move.at) / move.duration)
            eased = 0.5 - 0.5 * math.cos(math.pi * fraction)
            position = self._start + eased * (np.asarray(move.to) - self._start)
            events.append(("move", *to_window(position)))
            if fraction < 1.0:
                break
            events.append(("release", *to_window(position)))
            self._pressed = False
            self._next += 1
        return events


def main(argv: list[str] | None = None) -> int:
    """Draw every demo into a folder: the assets of the source tree, or ``--output DIR``."""
    parser = argparse.ArgumentParser(prog="python -m app.viewer.demos", description=main.__doc__)
    parser.add_argument(
        "--output",
        type=Path,
        default=ASSETS,
        required=ASSETS is None,
        help="folder to write NAME.png, NAME.cage.json, NAME.script.json and NAME.session.json into "
        "(default: the bundled assets, assets/ in the source tree)",
    )
    args = parser.parse_args(argv)
    for name in DEMOS:
        files = write_demo(name, args.output)
        print(f"{files.image}  {len(read_cage(files.cage))} control points", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
