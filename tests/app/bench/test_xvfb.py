"""app.bench.xvfb: how a bench row reads the viewer child it runs (its lines, a watchdog, what it said)."""

import subprocess
import sys
import time

from app.bench.xvfb import failure_details, viewer_lines


def _child(code: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def test_viewer_lines_stop_where_enough_says_and_the_child_has_exited():
    child = _child(
        "import sys, time\nprint('a'); print('  basis x=1  ', flush=True); time.sleep(0.5); print('b')"
    )
    lines = viewer_lines(child, 30.0, lambda line: line.startswith("basis "))
    assert lines == ["a", "basis x=1"]
    assert child.returncode == 0  # it ran to its end after the reading stopped


def test_viewer_lines_kill_a_child_that_outlives_the_timeout():
    child = _child("import time\nprint('started', flush=True); time.sleep(60)")
    start = time.monotonic()
    lines = viewer_lines(child, 1.0, lambda line: False)
    assert lines == ["started"]
    assert child.returncode is not None and child.returncode != 0
    assert time.monotonic() - start < 30.0  # killed by the watchdog, not left to sleep


def test_failure_details_name_the_last_lines_and_stderr():
    child = _child(
        "import sys\nprint('one\\ntwo\\nthree\\nfour'); sys.stderr.write('e1\\ne2\\ne3\\n'); sys.exit(3)"
    )
    lines = viewer_lines(child, 30.0, lambda line: False)
    assert child.returncode == 3
    assert failure_details(child, lines, 2) == "    two\n    three\n    four\n    e2\n    e3"
    quiet = _child("print('only')")
    lines = viewer_lines(quiet, 30.0, lambda line: False)
    assert failure_details(quiet, lines, 5) == "    only\n    (no output on stderr)"
