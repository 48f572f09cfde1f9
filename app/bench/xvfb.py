"""A private Xvfb server: a virtual screen for the viewer where there is none to borrow (the
bench's viewer rows; the tests, which drive the real window on it).

Xvfb takes the first free display number and writes it to a pipe once it accepts connections
(``-displayfd``): two servers started at once never share a number, as they could when a number
was picked first and Xvfb started on it (two test workers' viewers then shared one screen, and
each test's input could reach the other's window).
"""

from __future__ import annotations

import os
import select
import subprocess
import time

#: Seconds a server may take to say its display number.
START_TIMEOUT = 30.0


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
