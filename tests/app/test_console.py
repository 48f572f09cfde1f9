"""Tests of app.console: the progress bar, held-back notes and one-line failures."""

import io

import pytest

from app import console
from app.console import ProgressBar


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_bar_draws_on_a_terminal_only():
    terminal = Terminal()
    with ProgressBar("basis functions", terminal) as bar:
        for fraction in (0.0, 0.5, 0.501, 1.0):
            bar(fraction)
    text = terminal.getvalue()
    assert text.count("\r") == 3, "redraw only when the percentage changes"
    assert "[###############...............]  50%" in text and text.endswith("\n")
    terminal = Terminal()
    with pytest.raises(ValueError), ProgressBar("basis functions", terminal) as bar:
        bar(0.3)
        raise ValueError("bad kernel")
    drawn, wiped, rest = terminal.getvalue().split("\r")[1:]
    assert "30%" in drawn and wiped == " " * len(drawn) and rest == "", "a failed stage wipes its bar"
    pipe = io.StringIO()
    with ProgressBar("basis functions", pipe) as bar:
        bar(0.5)
    assert pipe.getvalue() == ""


def test_an_announcing_bar_says_what_waits_in_one_line_off_a_terminal():
    # animate, quality, bench and warp announce the solver's compilation even in a log.
    pipe = io.StringIO()
    with ProgressBar("compiling the solver (first use, ~15 s)", pipe, announce=True) as bar:
        for fraction in (0.0, 0.4, 1.0):
            bar(fraction)
    assert pipe.getvalue() == "compiling the solver (first use, ~15 s)...\n"
    assert bar.seconds is not None
    terminal = Terminal()
    with ProgressBar("compiling", terminal, announce=True) as bar:
        bar(0.0)
    assert terminal.getvalue().startswith("\rcompiling ["), "on a terminal the bar itself says it"
    quiet = io.StringIO()
    with ProgressBar("compiling", quiet, announce=True):
        pass  # never called: nothing compiled, nothing said
    assert quiet.getvalue() == ""


def test_notes_wait_for_success_and_a_failure_is_the_only_line(capsys):
    console.discard_notes()
    console.note("mesh: 12 vertices,\n 10 triangles")
    assert capsys.readouterr().err == ""
    console.print_notes()
    assert capsys.readouterr().err == "mesh: 12 vertices, 10 triangles\n"
    console.print_notes()
    assert capsys.readouterr().err == "", "printed once"
    console.note("wrote out.png")
    assert console.fail("error: out.png:\n cannot write", console.EXIT_BAD_INPUT) == 2
    console.print_notes()
    assert capsys.readouterr().err == "error: out.png: cannot write\n"


def test_a_bar_on_a_terminal_keeps_its_time_while_its_percentage_stays():
    # One long step (a large density solve) gives no fractions: the elapsed time is redrawn
    # every `tick` seconds meanwhile, and not after the bar ends.
    import time

    terminal = Terminal()
    with ProgressBar("basis functions", terminal, tick=0.02) as bar:
        bar(0.0)
        time.sleep(0.3)
        bar(1.0)
    text = terminal.getvalue()
    assert text.count("\r") >= 5 and text.count("  0% ") >= 4, "the time is redrawn at 0 %"
    assert text.endswith(" s\n") and float(text.rsplit("%", 1)[1].split()[0]) >= 0.3
    time.sleep(0.1)
    assert terminal.getvalue() == text, "nothing is drawn after the bar ends"
    terminal = Terminal()
    with ProgressBar("basis functions", terminal, tick=None) as bar:
        bar(0.0)
        time.sleep(0.1)
        bar(1.0)
    assert terminal.getvalue().count("\r") == 2
