"""A private Xvfb server: a virtual screen for the viewer where there is none to borrow (the
bench's viewer rows; the tests, which drive the real window on it); `viewer_lines`, how a bench
row reads the viewer it runs there.

Xvfb takes the first free display number and writes it to a pipe once it accepts connections
(``-displayfd``): two servers started at once never share a number, as they could when a number
was picked first and Xvfb started on it (two test workers' viewers then shared one screen, and
each test's input could reach the other's window).
"""

from __future__ import annotations

import os
import select
import subprocess
import threading
import time
from collections.abc import Callable

#: Seconds a server may take to say its display number.
START_TIMEOUT = 30.0
#: Seconds a viewer may take to exit once its lines are read.
EXIT_TIMEOUT = 60.0


def start_xvfb(size: tuple[int, int] = (1280, 1024)) -> tuple[subprocess.Popen, str]:
    """Start Xvfb with one screen of `size` (width, height) at 24 bits; returns (process, ":N").

    Raises
    ------
    RuntimeError
        Xvfb is not installed, or said no display number within `START_TIMEOUT` seconds.
    """
    read, write = os.pipe()
    try:
        process = subprocess.Popen(
            ["Xvfb", "-displayfd", str(write), "-screen", "0", f"{size[0]}x{size[1]}x24", "-nolisten", "tcp"],
            pass_fds=(write,),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    except FileNotFoundError:
        os.close(read)
        raise RuntimeError("Xvfb is not installed (apt-get install xvfb)") from None
    finally:
        os.close(write)
    number = b""
    deadline = time.monotonic() + START_TIMEOUT
    try:
        while not number.endswith(b"\n") and time.monotonic() < deadline:
            ready, _, _ = select.select([read], [], [], max(0.0, deadline - time.monotonic()))
            chunk = os.read(read, 16) if ready else b""
            if not chunk:
                break
            number += chunk
    finally:
        os.close(read)
    if not number.strip().isdigit():
        process.kill()
        process.wait()
        raise RuntimeError(f"Xvfb did not start (no display number within {START_TIMEOUT:g} s)")
    return process, f":{int(number)}"


def viewer_lines(child: subprocess.Popen, timeout: float, enough: Callable[[str], bool]) -> list[str]:
    """The lines a viewer `child` printed (its test hook's milestones, one a line), stripped.

    Each line goes to `enough` as it comes; reading stops at the first for which it returns True
    (or at the child's end).  The child is killed once `timeout` seconds have passed since the call,
    or if it has not exited `EXIT_TIMEOUT` seconds after the reading stopped; it has exited when
    this returns.
    """
    lines = []
    watchdog = threading.Timer(timeout, child.kill)
    watchdog.start()
    try:
        for line in child.stdout:
            lines.append(line.strip())
            if enough(lines[-1]):
                break
        child.wait(timeout=EXIT_TIMEOUT)
    finally:
        watchdog.cancel()
        if child.poll() is None:
            child.kill()
            child.wait()
    return lines


def failure_details(child: subprocess.Popen, lines: list[str], errors: int) -> str:
    """What a failed viewer `child` said: its last 3 `lines` and last `errors` lines on stderr,
    indented, one a line."""
    said = child.stderr.read().strip().splitlines()[-errors:] or ["(no output on stderr)"]
    return "\n".join(f"    {line}" for line in [*lines[-3:], *said])
