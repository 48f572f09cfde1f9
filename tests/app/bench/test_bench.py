"""Tests of app.bench.table: a smoke test of the whole table at tiny sizes, its error reporting, and
its rows one by one."""

import argparse
import re
import subprocess
import sys

import pytest
from support.paths import ROOT

from app.bench import fold_free as bench_fold_free
from app.bench import fold_free_drag as bench_fold_free_drag
from app.bench import fold_free_held_out as bench_held_out
from app.bench import mesher as bench_mesher
from app.bench import pins as bench_pins
from app.bench import table as bench
from app.bench.table import StepFailed, run_child

pytestmark = pytest.mark.slow


def test_the_whole_quick_table_runs():
    # A smoke test of `python -m app bench` at tiny sizes, so that the table never rots;
    # speed itself is measured by the bench, not by tests. The launch and pins rows have tests of
    # their own below, which this one would repeat (~8 s).
    skipped = ["--skip-memory", "--skip-warp", "--skip-launch", "--skip-pins"]
    command = ["bench", "--quick", "--repeats", "1", *skipped]
    result = subprocess.run(
        [sys.executable, "-m", "app", *command],
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=True,
    )
    assert "harmonic-like" in result.stdout and "FEM / poisson" in result.stdout
    # The animation row: GIF and PNG frames in turns, each with its own peak memory.
    pattern = (
        r"animate 600x400, 0\.25 s at 30 fps, --outside original \(median of 1, in turns\): GIF [\d.]+ s, "
        r"PNG frames [\d.]+ s, GIF / PNG frames = [\d.]+; "
        r"peak memory: GIF ([\d.]+) GiB, PNG frames ([\d.]+) GiB"
    )
    (match,) = filter(None, (re.fullmatch(pattern, line) for line in result.stdout.splitlines()))
    assert all(0.05 < float(peak) < 1.0 for peak in match.groups()), match.group(0)
    # The viewer's drag frame at ~6k vertices under Xvfb (or the line saying it was skipped), and
    # its fold-free drag frame.
    assert "viewer drag frame" in result.stdout and "viewer fold-free drag frame" in result.stdout


def test_a_failed_child_shows_its_own_error():
    code = (
        "import sys; print('compiling', file=sys.stderr); sys.exit('error: shader mesh.vert.glsl not found')"
    )
    with pytest.raises(StepFailed) as raised:
        run_child([sys.executable, "-c", code], "the 640x360 warp")
    assert str(raised.value) == (
        "the 640x360 warp failed with exit code 1:\n    compiling\n    error: shader mesh.vert.glsl not found"
    )
    assert run_child([sys.executable, "-c", "print(42)"], "a row").stdout == "42\n"


def test_a_failed_row_is_reported_and_the_others_still_run(monkeypatch, capsys):
    ran = []

    def fail(*args):
        ran.append("memory")
        raise StepFailed("the 20,000-point memory run failed with exit code 1:\n    MemoryError")

    monkeypatch.setattr(bench, "_warm_up", lambda curve: None)
    monkeypatch.setattr(bench, "_point_kernels", lambda *args: None)
    monkeypatch.setattr(bench, "_memory", fail)
    monkeypatch.setattr(bench, "_warp_4k", lambda size: ran.append("warp"))
    args = argparse.Namespace(
        quick=True,
        repeats=1,
        large=False,
        skip_fem=True,
        skip_memory=False,
        skip_warp=False,
        skip_photos=True,
        skip_drag=True,
        skip_launch=True,
        skip_export=True,
        skip_fold_free=True,
        skip_mesher=True,
        skip_pins=True,
    )
    assert bench.run_bench(args) == 1
    assert ran == ["memory", "warp"]
    assert (
        capsys.readouterr().err
        == "bench: the 20,000-point memory run failed with exit code 1:\n    MemoryError\n"
    )


def test_the_drag_frame_says_it_is_skipped_without_xvfb(monkeypatch, capsys):
    monkeypatch.setattr(bench.shutil, "which", lambda name: None)
    bench._drag_frames((6_000,))
    assert capsys.readouterr().out == "viewer drag frame: skipped: no Xvfb (apt-get install xvfb)\n"


def test_the_fold_free_drag_frame_says_it_is_skipped_without_xvfb(monkeypatch, capsys):
    monkeypatch.setattr(bench_fold_free_drag.shutil, "which", lambda name: None)
    bench_fold_free_drag.fold_free_drag_row(StepFailed)
    assert capsys.readouterr().out == "viewer fold-free drag frame: skipped: no Xvfb (apt-get install xvfb)\n"


def test_the_gif_export_row_says_it_is_skipped_without_xdotool(monkeypatch, capsys):
    monkeypatch.setattr(bench.shutil, "which", lambda name: None if name == "xdotool" else "/usr/bin/" + name)
    bench._export_gif(1, bench.QUICK_EXPORT_FPS)
    assert capsys.readouterr().out == (
        "viewer GIF export: skipped: needs Xvfb and xdotool (apt-get install xvfb xdotool)\n"
    )


def test_the_fem_comparison_alternates_its_runs_after_a_pause(monkeypatch):
    # Each method is timed in turn, after a pause that lets the other's BLAS threads sleep.
    events = []
    monkeypatch.setattr(bench.time, "sleep", lambda seconds: events.append(("sleep", seconds)))
    clock = iter(range(100))
    monkeypatch.setattr(bench.time, "perf_counter", lambda: next(clock) ** 2)
    fem, ours = bench._alternating_medians(
        (lambda: events.append("fem"), lambda: events.append("ours")), repeats=3
    )
    pause = ("sleep", bench.BLAS_SETTLE)
    assert events == [pause, "fem", pause, "ours"] * 3
    # Runs take 1, 5, 9, 13, 17, 21 clock units (squares of consecutive readings), in turn.
    assert (fem, ours) == (9, 13)


def test_short_fem_rows_run_until_each_solve_has_run_long_enough(monkeypatch):
    monkeypatch.setattr(bench.time, "sleep", lambda seconds: None)
    readings = iter(range(1000))
    monkeypatch.setattr(bench.time, "perf_counter", lambda: 0.125 * next(readings))  # every run 1/8 s
    calls = {"fem": 0, "ours": 0}

    def counted(name):
        return lambda: calls.__setitem__(name, calls[name] + 1)

    medians = bench._alternating_medians((counted("fem"), counted("ours")), repeats=3, least_seconds=1.0)
    assert calls == {"fem": 8, "ours": 8}  # 8 x 1/8 s each, more than the 3 asked for
    assert medians == [0.125, 0.125]
    calls.update(fem=0, ours=0)
    bench._alternating_medians((counted("fem"), counted("ours")), repeats=3, least_seconds=1e6)
    assert calls == {"fem": bench.MAX_REPEATS, "ours": bench.MAX_REPEATS}
    calls.update(fem=0, ours=0)
    bench._alternating_medians((counted("fem"), counted("ours")), repeats=4, least_seconds=0.25)
    assert calls == {"fem": 4, "ours": 4}  # long enough already: the runs asked for


def test_quick_runs_every_row_once_at_tiny_sizes(monkeypatch):
    # --quick used to time the FEM rows again and again for ROW_SECONDS and drag for 4 s: 30 s or more.
    calls = {}
    monkeypatch.setattr(bench, "_warm_up", lambda curve: None)
    monkeypatch.setattr(bench, "_point_kernels", lambda curve, sizes, *rest: calls.update(points=sizes))
    monkeypatch.setattr(bench, "_fem_comparison", lambda curve, *rest: calls.update(fem=rest), raising=True)
    monkeypatch.setattr(bench, "_memory", lambda curve, count: calls.update(memory=count))
    monkeypatch.setattr(bench, "_warp_4k", lambda size: calls.update(warp=size))
    monkeypatch.setattr(bench, "_drag_frames", lambda *rest: calls.update(drag=rest))
    monkeypatch.setattr(bench, "_export_gif", lambda *rest: calls.update(export=rest))
    monkeypatch.setattr(
        bench_fold_free_drag, "fold_free_drag_row", lambda failed, *rest: calls.update(fold_free_drag=rest)
    )
    monkeypatch.setattr(
        bench, "launch_rows", lambda repeats, quick, *rest: calls.update(launch=(repeats, quick))
    )
    monkeypatch.setattr(
        bench, "photo_rows", lambda sizes, run, *repeats: calls.update(photos=(sizes, *repeats))
    )
    monkeypatch.setattr(bench, "animation_row", lambda run, *rest: calls.update(animation=rest))
    monkeypatch.setattr(bench_pins, "pin_rows", lambda *rest: calls.update(pins=rest))
    monkeypatch.setattr(
        bench_fold_free,
        "fold_free_rows",
        lambda curve, repeats, forget, vertices: calls.update(fold_free=vertices),
    )
    monkeypatch.setattr(bench_held_out, "held_out_rows", lambda forget, quick: calls.update(held_out=quick))
    monkeypatch.setattr(
        bench_fold_free, "large_cage_row", lambda repeats, *count: calls.update(large_cage=(repeats, *count))
    )
    monkeypatch.setattr(
        bench_mesher, "mesher_rows", lambda curve, repeats, vertices: calls.update(mesher=(repeats, vertices))
    )
    args = argparse.Namespace(
        quick=True,
        repeats=3,
        large=False,
        skip_fem=False,
        skip_memory=False,
        skip_warp=False,
        skip_photos=False,
        skip_drag=False,
        skip_launch=False,
        skip_export=False,
        skip_fold_free=False,
        skip_mesher=False,
        skip_pins=False,
    )
    assert bench.run_bench(args) == 0
    assert calls == {
        "points": (500,),
        "fem": ((2_000,), 1, 0.0),
        "memory": 20_000,
        "warp": (640, 360),
        "photos": (((1200, 800),), 1),  # each warp once
        "animation": ((600, 400), 0.25, 1),
        "drag": ((6_000,), 1.0),
        "fold_free_drag": (0.5,),
        "export": (1, 1.0),  # 8 frames instead of the default 30 fps' 220
        "launch": (3, True),
        "fold_free": (2_000,),
        "held_out": True,
        "large_cage": (1, 40),
        "mesher": (1, (2_000,)),
        "pins": ((16,), 2, 1),
    }


def test_the_pins_row_proves_the_bound(capsys):
    bench_pins.pin_rows((16,), 2, 1)
    row = capsys.readouterr().out.strip().splitlines()[-1].split()
    assert row[0] == "16" and 1.0 <= float(row[4]) <= bench_pins.MAX_DISTORTION + 1e-5


def test_the_fold_free_row_says_when_libigl_is_missing(monkeypatch, capsys):
    """Without libigl the row times ours alone and says so; libigl is never needed at run time."""
    import core
    from core.curves import examples

    monkeypatch.setitem(sys.modules, "igl", None)  # `import igl` raises ImportError
    curve = core.ClosedBSpline(examples.blob() * 1000.0)
    bench_fold_free.fold_free_rows(curve, 1, lambda: None, (300,))
    out = capsys.readouterr().out
    assert "libigl is not installed" in out
    row = out.strip().splitlines()[-1].split()
    assert row[2] != "0" and row[3] == "0" and row[4] == "yes"  # steps, flips, proven


def test_the_large_cage_row_proves_the_certificate_and_maps_the_drag(capsys):
    """The row's columns on a 40-point lobed circle (the bench's has 200): the certificate of the small
    drag proven, the folding drag's map with no triangle turned over, proven."""
    bench_fold_free.large_cage_row(1, count=40)
    row = capsys.readouterr().out.strip().splitlines()[-1].split()
    assert float(row[0]) > 0 and row[2] == "yes" and int(row[3]) > 0
    assert row[6] == "0" and row[7] == "yes"


def test_the_mesher_row_says_when_triangle_is_missing(monkeypatch, capsys):
    """Without the triangle package the row times ours alone and says so; it is never needed at run time."""
    import core
    from core.curves import examples

    monkeypatch.setitem(sys.modules, "triangle", None)  # `import triangle` raises ImportError
    curve = core.ClosedBSpline(examples.blob() * 1000.0)
    bench_mesher.mesher_rows(curve, 1, (300,))
    out = capsys.readouterr().out
    assert "triangle is not installed" in out
    target, vertices, seconds = out.strip().splitlines()[-1].split()
    # a coarse mesh: its boundary vertices add to the estimate from the area
    assert target == "300" and 300 <= int(vertices) < 600 and float(seconds) > 0


def test_triangle_gets_the_closed_boundary_polygon_of_our_mesh():
    import core
    from core.curves import examples

    mesh = core.triangulate(core.ClosedBSpline(examples.blob() * 1000.0), max_edge=100.0)
    graph = bench_mesher.triangle_input(mesh)
    count = mesh.boundary.size
    assert graph["vertices"].shape == (count, 2)
    assert (graph["vertices"] == mesh.vertices[mesh.boundary]).all()
    assert sorted(graph["segments"][:, 0]) == list(range(count))
    assert ((graph["segments"][:, 1] - graph["segments"][:, 0]) % count == 1).all()


def test_the_launch_rows_time_the_demo_and_a_photograph_to_their_first_basis(capsys):
    from app.bench.launch import launch_rows

    launch_rows(1, True, bench._started_xvfb, StepFailed)
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("viewer launch to a warpable picture (process start to the basis drawn")
    labels = ["demo, basis not cached", "demo, basis cached", "1200x800 JPEG, cage fitted"]
    for line, label in zip(lines[1:4], labels, strict=True):
        seconds = float(line.split()[-4])
        assert line.strip().startswith(label) and 0.2 < seconds < 60.0, line  # a generous limit
