"""Driving the real viewer window under Xvfb: the server, xdotool input and screenshots.

Used by tests/app/viewer/test_window.py.  Screenshots read the X server's root window
through libX11 (ctypes), so no ImageMagick or xwd is needed; input goes through
xdotool, i.e. real X events that glfw receives like a user's.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import json
import os
import shutil
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from support import warm_start
from support.paths import ROOT


def start_xvfb(size=(1280, 1024)) -> tuple[subprocess.Popen, str]:
    """Start a private Xvfb server (`app.bench.xvfb.start_xvfb`); returns (process, ":N").

    Raises RuntimeError (so the test fails, never skips) if Xvfb or xdotool is missing or Xvfb
    does not start.
    """
    from app.bench.xvfb import start_xvfb as started

    if shutil.which("xdotool") is None:
        raise RuntimeError("xdotool is not installed (apt-get install xdotool)")
    return started(size)


def xdotool(display: str, *args: str) -> str:
    """Run xdotool on `display`; returns its stdout."""
    result = subprocess.run(
        ["xdotool", *args], env={**os.environ, "DISPLAY": display}, capture_output=True, text=True, timeout=20
    )
    if result.returncode != 0:
        raise RuntimeError(f"xdotool {' '.join(args)} failed: {result.stderr.strip()}")
    return result.stdout


class _XImage(ctypes.Structure):
    _fields_ = [
        ("width", ctypes.c_int),
        ("height", ctypes.c_int),
        ("xoffset", ctypes.c_int),
        ("format", ctypes.c_int),
        ("data", ctypes.POINTER(ctypes.c_ubyte)),
        ("byte_order", ctypes.c_int),
        ("bitmap_unit", ctypes.c_int),
        ("bitmap_bit_order", ctypes.c_int),
        ("bitmap_pad", ctypes.c_int),
        ("depth", ctypes.c_int),
        ("bytes_per_line", ctypes.c_int),
        ("bits_per_pixel", ctypes.c_int),
        ("red_mask", ctypes.c_ulong),
        ("green_mask", ctypes.c_ulong),
        ("blue_mask", ctypes.c_ulong),
    ]


def screenshot(display: str) -> np.ndarray:
    """The whole screen of `display` as RGB, ndarray of shape (H, W, 3), uint8, row 0 at the top."""
    x11 = ctypes.cdll.LoadLibrary(ctypes.util.find_library("X11") or "libX11.so.6")
    x11.XOpenDisplay.restype = ctypes.c_void_p
    x11.XOpenDisplay.argtypes = [ctypes.c_char_p]
    x11.XDefaultRootWindow.restype = ctypes.c_ulong
    x11.XDefaultRootWindow.argtypes = [ctypes.c_void_p]
    x11.XGetImage.restype = ctypes.POINTER(_XImage)
    x11.XGetImage.argtypes = [
        ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_int,
        ctypes.c_uint, ctypes.c_uint, ctypes.c_ulong, ctypes.c_int,
    ]  # fmt: skip
    x11.XDisplayWidth.argtypes = x11.XDisplayHeight.argtypes = [ctypes.c_void_p, ctypes.c_int]
    x11.XFree.argtypes = [ctypes.c_void_p]
    x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
    handle = x11.XOpenDisplay(display.encode())
    if not handle:
        raise RuntimeError(f"cannot open X display {display}")
    try:
        width, height = x11.XDisplayWidth(handle, 0), x11.XDisplayHeight(handle, 0)
        all_planes, z_pixmap = 0xFFFFFFFF, 2
        image = x11.XGetImage(
            handle, x11.XDefaultRootWindow(handle), 0, 0, width, height, all_planes, z_pixmap
        )
        if not image:
            raise RuntimeError("XGetImage failed")
        content = image.contents
        if content.bits_per_pixel != 32:
            raise RuntimeError(f"expected 32 bits per pixel, got {content.bits_per_pixel}")
        stride = content.bytes_per_line  # read before XFree: `content` is the freed struct after it
        raw = np.ctypeslib.as_array(content.data, shape=(stride * content.height,)).copy()
        x11.XFree(ctypes.cast(content.data, ctypes.c_void_p))
        x11.XFree(ctypes.cast(image, ctypes.c_void_p))
    finally:
        x11.XCloseDisplay(handle)
    pixels = raw.reshape(height, stride // 4, 4)[:, :width]
    return pixels[..., [2, 1, 0]].copy()  # BGRX (little endian) -> RGB


def save_png(path: str | os.PathLike, rgb: np.ndarray) -> None:
    """Write an RGB screenshot as PNG (for people to look at)."""
    import cv2

    cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))


class _ClientMessage(ctypes.Structure):
    _fields_ = [
        ("type", ctypes.c_int),
        ("serial", ctypes.c_ulong),
        ("send_event", ctypes.c_int),
        ("display", ctypes.c_void_p),
        ("window", ctypes.c_ulong),
        ("message_type", ctypes.c_ulong),
        ("format", ctypes.c_int),
        ("data", ctypes.c_long * 5),
        ("pad", ctypes.c_long * 12),  # XEvent is 24 longs
    ]


def close_window(display: str, window: int) -> None:
    """Ask `window` to close like a window manager's close button (WM_DELETE_WINDOW)."""
    x11 = ctypes.cdll.LoadLibrary(ctypes.util.find_library("X11") or "libX11.so.6")
    x11.XOpenDisplay.restype = ctypes.c_void_p
    x11.XOpenDisplay.argtypes = [ctypes.c_char_p]
    x11.XInternAtom.restype = ctypes.c_ulong
    x11.XInternAtom.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_int]
    x11.XSendEvent.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_long, ctypes.c_void_p]
    x11.XFlush.argtypes = x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
    handle = x11.XOpenDisplay(display.encode())
    if not handle:
        raise RuntimeError(f"cannot open X display {display}")
    try:
        event = _ClientMessage()
        event.type = 33  # ClientMessage
        event.window = window
        event.message_type = x11.XInternAtom(handle, b"WM_PROTOCOLS", 0)
        event.format = 32
        event.data[0] = x11.XInternAtom(handle, b"WM_DELETE_WINDOW", 0)
        event.data[1] = 0  # CurrentTime
        if not x11.XSendEvent(handle, window, 0, 0, ctypes.byref(event)):
            raise RuntimeError("XSendEvent failed")
        x11.XFlush(handle)
    finally:
        x11.XCloseDisplay(handle)


class ViewerProcess:
    """``python -m app ...`` in a process of its own (forked from the warm server, `support.warm_start`)
    with the viewer's test hook, its stdout read line by line.

    Parameters
    ----------
    args : list of str
        Arguments after ``python -m app``.
    env : dict
        Environment (DISPLAY, cache and state directories); the test hook is added.
    cwd : path-like
        The repository root.
    window_size : (int, int) or None
        ``--window-size`` (the tests' screen positions are laid out for 1280x1024); None: the
        viewer's own choice (the size it last had, or one that fits the screen).
    """

    def __init__(self, args: list[str], env: dict, cwd, window_size=(1280, 1024)):
        import queue
        import threading

        self.lines: list[str] = []
        self._queue: queue.Queue = queue.Queue()
        size = [] if window_size is None else ["--window-size", "{}x{}".format(*window_size)]
        self.process = warm_start.start([*args, *size], {**env, "TRANSFINITE_VIEWER_TEST": "1"}, cwd)
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in self.process.stdout:
            self._queue.put(line.rstrip("\n"))
        self._queue.put(None)

    def wait_for(self, prefix: str, timeout: float = 60.0) -> str:
        """The next stdout line starting with `prefix` (earlier lines are kept in `lines`)."""
        import queue

        deadline = time.monotonic() + timeout
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise AssertionError(f"no {prefix!r} line within {timeout} s; got {self.lines}")
            try:
                line = self._queue.get(timeout=remaining)
            except queue.Empty:
                continue
            if line is None:
                stderr = self.process.stderr.read()
                raise AssertionError(f"the viewer exited before {prefix!r}: {self.lines}\n{stderr}")
            self.lines.append(line)
            if line.startswith(prefix):
                return line

    def finish(self, timeout: float = 20.0) -> tuple[int, str]:
        """Wait for the process to exit; (exit code, stderr)."""
        code = self.process.wait(timeout=timeout)
        import queue

        while True:
            try:
                line = self._queue.get(timeout=2)
            except queue.Empty:
                break
            if line is None:
                break
            self.lines.append(line)
        return code, self.process.stderr.read()

    def descendants(self) -> list[int]:
        """The process ids of the viewer's workers and their children (Linux: /proc)."""
        found, waiting = [], [self.process.pid]
        while waiting:
            pid = waiting.pop()
            for task in Path(f"/proc/{pid}/task").glob("*"):
                try:
                    children = [int(child) for child in (task / "children").read_text().split()]
                except OSError:
                    continue
                found += children
                waiting += children
        return found

    def kill(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait()


def wait_until_ended(pids: list[int], timeout: float) -> list[int]:
    """Wait up to `timeout` seconds for the processes `pids` (not this process's children) to end;
    those still running then (zombies count as ended)."""
    deadline = time.monotonic() + timeout
    while True:
        running = []
        for pid in pids:
            try:
                state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
            except OSError:
                continue
            if state != "Z":
                running.append(pid)
        if not running or time.monotonic() > deadline:
            return running
        time.sleep(0.1)


@pytest.fixture(scope="module")
def display():
    process, name = start_xvfb()
    yield name
    process.terminate()
    process.wait(timeout=10)


def session_points(path: Path) -> tuple[np.ndarray, np.ndarray, dict]:
    value = json.loads(path.read_text())
    return (
        np.array(value["cage"]["control_points"]),
        np.array(value["target"]["control_points"]),
        value,
    )


def window_pixel(view: dict, point) -> np.ndarray:
    return np.asarray(view["offset"]) + view["scale"] * np.asarray(point)


def press_and_move(display: str, window: str, start: np.ndarray, offset: np.ndarray) -> None:
    """Press on `start` (window pixels) and move by `offset` in ten steps, button still down."""
    xdotool(display, "mousemove", "--window", window, *(f"{v:.0f}" for v in start))
    time.sleep(0.2)
    xdotool(display, "mousedown", "1")
    for step in np.linspace(0.1, 1.0, 10):
        xdotool(display, "mousemove", "--window", window, *(f"{v:.0f}" for v in start + step * offset))
        time.sleep(0.03)


def drag_point(display: str, window: str, start: np.ndarray, offset: np.ndarray) -> None:
    """`press_and_move`, then release: real X events."""
    press_and_move(display, window, start, offset)
    xdotool(display, "mouseup", "1")


def wait_for_session(path: Path, predicate, timeout: float = 10.0):
    """The session file's (cage, target, value) once `predicate` holds for them."""
    deadline = time.monotonic() + timeout
    while True:
        points = session_points(path)
        if predicate(*points):
            return points
        if time.monotonic() > deadline:
            raise AssertionError(f"{path} did not reach the expected state: {points[2]['view']}")
        time.sleep(0.1)


def shot(display: str, folder: Path, name: str) -> np.ndarray:
    """Screenshot of the whole screen (the window covers it), also saved as PNG."""
    time.sleep(0.4)  # a few frames for the last event to be drawn
    pixels = screenshot(display)
    save_png(folder / f"{name}.png", pixels)
    keep = os.environ.get("VIEWER_SCREENSHOTS")
    if keep:
        Path(keep).mkdir(parents=True, exist_ok=True)
        save_png(Path(keep) / f"{name}.png", pixels)
    return pixels.astype(np.int16)


#: Window pixels (1280x1024): the side panel's right edge and the status line's top.
PANEL_RIGHT, STATUS_TOP = 300, 990


def changed_fraction(a: np.ndarray, b: np.ndarray) -> float:
    """Fraction of canvas pixels (right of the panel, above the status line) that differ visibly."""
    canvas = (slice(0, STATUS_TOP), slice(PANEL_RIGHT, None))
    return float((np.abs(a[canvas] - b[canvas]).max(axis=-1) > 40).mean())


def park_mouse(display: str, window: str) -> None:
    """Move the pointer onto empty canvas, so no handle shows as hovered."""
    xdotool(display, "mousemove", "--window", window, "1250", "40")


#: The bundled starfish demo's cage, (n, 2).
STARFISH_CAGE = np.array(
    json.loads((ROOT / "assets" / "starfish.cage.json").read_text())["control_points"], dtype=float
)
STARFISH_CAGE.flags.writeable = False  # shared by the tests: none may move it for another


def viewer_environment(display: str, folder: Path) -> dict:
    """The environment of a viewer on `display` with its cache and state folders in `folder`."""
    return {
        **os.environ,
        "DISPLAY": display,
        "TRANSFINITE_CACHE_DIR": str(folder / "cache"),
        "TRANSFINITE_STATE_DIR": str(folder / "state"),
    }


def starfish_session(path: Path, view: dict, keyframes=()) -> None:
    """Write a session of the starfish demo at rest (target = cage) seen through `view`, with
    keyframes of the rest pose at the times `keyframes`."""
    rest = {"control_points": STARFISH_CAGE.tolist()}
    value = {
        "image": str(ROOT / "assets" / "starfish.png"),
        "cage": rest,
        "target": rest,
        "kernel": "poisson",
        "view": view,
        "keyframes": [{"time": t, "target": rest} for t in keyframes],
    }
    path.write_text(json.dumps(value))
