"""One warp pipeline (app.warp.pipeline): `warp`, `animate`, the viewer's export and `quality` draw or
measure the same deformation of the same mesh."""

import json

import numpy as np
import pytest
from support.commands import CAGE, picture, run_main, transformed

import app.warp.pipeline
import core
from app.io.files import read_image, write_png
from app.viewer.exports import Exporter
from app.viewer.precompute import compute, make_request, result_from_message
from app.viewer.scene import Scene
from app.viewer.state import AppState, Document, History, Snapshot

MAX_EDGE = 9.0
#: The picture's cage and its target, of every test but the fold-free ones.
CAGE_POINTS, MOVED = np.array(CAGE, dtype=float), transformed(CAGE)


def write_session(folder, **fields) -> None:
    """Write ``picture.png`` and ``session.json`` into `folder`: the picture, `CAGE_POINTS` moved to
    `MOVED`, the default kernel, seen at scale 1, with `fields` added or replaced."""
    write_png(folder / "picture.png", picture())
    session = {
        "image": "picture.png",
        "cage": {"control_points": CAGE_POINTS.tolist()},
        "target": {"control_points": MOVED.tolist()},
        "kernel": "poisson",
        "view": {"scale": 1.0, "offset": [0, 0]},
        **fields,
    }
    (folder / "session.json").write_text(json.dumps(session))


def viewer_state(snapshot: Snapshot, image: np.ndarray, folder, max_edge: float = MAX_EDGE) -> AppState:
    """The viewer's state of `snapshot` over `image`, its session in `folder`, its basis computed by
    the precompute worker's function."""
    request = make_request(snapshot, max_edge)
    state = AppState(Document(History(snapshot), snapshot, image, folder / "s.json"))
    state.compute.basis = result_from_message(request.key, compute(request))
    return state


@pytest.fixture(autouse=True)
def private_cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("TRANSFINITE_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))


@pytest.fixture
def spied(monkeypatch):
    """The names of the commands that called `app.warp.pipeline.prepare` and `render`, in order."""
    calls = []
    for name in ("prepare", "render"):
        original = getattr(app.warp.pipeline, name)

        def spy(*arguments, original=original, name=name, **keywords):
            calls.append(name)
            return original(*arguments, **keywords)

        monkeypatch.setattr(app.warp.pipeline, name, spy)
    return calls


def test_warp_animate_the_viewer_export_and_quality_share_one_pipeline(tmp_path, capfd, renderer, spied):
    cage, moved = CAGE_POINTS, MOVED
    keyframes = [{"time": t, "target": {"control_points": moved.tolist()}} for t in (0.0, 1.0)]
    write_session(tmp_path, keyframes=keyframes)
    limit = ["--max-edge", str(MAX_EDGE)]

    warp_argv = ["warp", "--session", tmp_path / "session.json", "--output", tmp_path / "warp.png", *limit]
    code, _, err = run_main(warp_argv, capfd)
    assert code == 0, err
    assert spied == ["prepare", "render"]
    warped = read_image(tmp_path / "warp.png")

    frames = tmp_path / "frames"
    animate_argv = ["animate", tmp_path / "session.json", "--output", f"{frames}/", "--fps", "2", *limit]
    assert run_main(animate_argv, capfd)[0] == 0
    assert spied[2:] == ["prepare", "render", "render", "render"]
    for frame in sorted(frames.iterdir()):
        np.testing.assert_array_equal(read_image(frame), warped)

    # The viewer: its worker's precompute, its scene, and the export of the current target.
    state = viewer_state(Snapshot(tmp_path / "picture.png", cage, moved), picture(), tmp_path)
    key = state.compute.basis.key
    state.selection.edit_mode = "deform"
    # warp and animate made their own GL contexts current and released them: the fixture's
    # renderer draws in its own context again, made current for the viewer's part (then restored).
    with renderer.ctx:
        scene = Scene(renderer)
        exporter = Exporter(state, scene, lambda s: s.compute.basis.key == key, None, 30.0, print, None)
        scene.sync(state)
        np.testing.assert_array_equal(exporter.render_still(), warped)
    assert spied[6:] == ["prepare", "render"]

    # quality measures the positions of the same preparation.
    from app.studies.quality import KernelChoice, run_study
    from app.studies.quality_suite import Deformation, Domain

    domain = Domain("picture", cage, [Deformation("moved", moved)])
    study = run_study([domain], [KernelChoice("poisson", "poisson")], keep=True)
    assert spied[8:] == ["prepare", "prepare"]  # the FEM reference, then poisson
    expected = app.warp.pipeline.prepare(
        core.ClosedBSpline(cage), app.warp.pipeline.WarpSettings(cache=False), study.meshes["picture"]
    )
    # The same basis but for rounding: one suite run in many, on a loaded machine, differed from the
    # second computation by 1e-15 (in the last bits of 81 % of the entries).
    np.testing.assert_allclose(study.bases["picture", "poisson"], expected.basis, rtol=0, atol=1e-14)


def test_prepare_uses_the_given_mesh_and_the_default_kernel():
    curve = core.ClosedBSpline(np.array(CAGE, dtype=float))
    mesh = core.triangulate(curve, max_edge=12.0)
    fractions = []
    deformation = app.warp.pipeline.prepare(
        curve, app.warp.pipeline.WarpSettings(cache=False), mesh, fractions.append
    )
    assert deformation.mesh is mesh and deformation.kernel == core.DEFAULT_KERNEL == "poisson"
    assert fractions[0] == 0.0 and fractions[-1] == 1.0
    np.testing.assert_allclose(deformation.positions(curve.control_points), mesh.vertices, atol=1e-7)


def test_a_fold_free_map_reports_the_share_of_the_path_proven_and_is_kept_for_its_target():
    from support.fold_free_checks import STARFISH, strong_target

    curve = core.ClosedBSpline(STARFISH)
    mesh = core.triangulate(curve, max_edge=12.0)
    deformation = app.warp.pipeline.prepare(
        curve, app.warp.pipeline.WarpSettings(cache=False, fold_free=True), mesh
    )
    shares = []
    positions, certificate = deformation.fold_free_map(strong_target(), shares.append)
    assert len(shares) >= certificate.extra["steps"] > 1
    assert shares == sorted(shares) and shares[-1] == 1.0
    assert deformation.positions(strong_target()) is positions  # kept: the report and the render ask again


def test_the_viewers_fold_free_export_is_warps_fold_free_session(tmp_path, capfd):
    from support.fold_free_checks import ASSETS, STARFISH, strong_target

    from app.render.renderer import WarpRenderer, create_headless_context

    target = strong_target()  # the plain map folds there
    session = {
        "image": str(ASSETS / "starfish.png"),
        "cage": {"control_points": STARFISH.tolist()},
        "target": {"control_points": target.tolist()},
        "kernel": "poisson",
        "view": {"scale": 1.0, "offset": [0, 0]},
        "mesh": {"max_edge": 12.0},
        "fold_free": True,
    }
    (tmp_path / "session.json").write_text(json.dumps(session))
    argv = ["warp", "--session", tmp_path / "session.json", "--output", tmp_path / "warp.png"]
    code, _, err = run_main(argv, capfd)
    assert code == 0, err
    warped = read_image(tmp_path / "warp.png")

    snapshot = Snapshot(ASSETS / "starfish.png", STARFISH, target, fold_free=True)
    state = viewer_state(snapshot, read_image(ASSETS / "starfish.png"), tmp_path, max_edge=12.0)
    ctx = create_headless_context()  # as warp's: its own, made after warp released its own
    try:
        with WarpRenderer(ctx) as renderer:
            scene = Scene(renderer)
            exporter = Exporter(state, scene, lambda s: True, None, 30.0, print, None)
            scene.sync(state)
            np.testing.assert_array_equal(exporter.render_still(), warped)
            state.document.live = snapshot.replace(fold_free=False)
            assert not np.array_equal(exporter.render_still(), warped)  # the plain map's pixels differ
    finally:
        ctx.release()


def test_the_viewers_background_is_saved_and_drawn_as_warp_draws_it(tmp_path, capfd, ctx):
    from app.io.session import read_session
    from app.render.renderer import WarpRenderer
    from app.viewer import commands
    from app.viewer.documents import restore, save

    write_png(tmp_path / "picture.png", picture())
    state = viewer_state(Snapshot(tmp_path / "picture.png", CAGE_POINTS, MOVED), picture(), tmp_path)
    key = state.compute.basis.key
    commands.command(state, "background", "mauve")
    assert state.status.message_is_error and state.document.background == "none"
    commands.command(state, "background", "#0000ff")
    assert state.document.background == "#0000ff" and state.document.session_dirty
    save(state, MAX_EDGE)
    assert read_session(tmp_path / "s.json").output.background == "#0000ff"
    assert restore(tmp_path / "s.json").preferences.output.background == "#0000ff"
    # An earlier test's warp made its own context current and released it: this one is made current.
    with ctx, WarpRenderer(ctx) as renderer:
        scene = Scene(renderer)
        exporter = Exporter(state, scene, lambda s: s.compute.basis.key == key, None, 30.0, print, None)
        scene.sync(state)
        exported = exporter.render_still()
    assert (exported[..., 3] == 255).all() and (exported == [0, 0, 255, 255]).all(axis=2).any()
    # warp --session takes the session's background: the same pixels, and a JPEG needs no option.
    argv = ["warp", "--session", tmp_path / "s.json", "--max-edge", str(MAX_EDGE)]
    code, _, err = run_main([*argv, "--output", tmp_path / "warp.png"], capfd)
    assert code == 0, err
    np.testing.assert_array_equal(exported, read_image(tmp_path / "warp.png"))
    assert run_main([*argv, "--output", tmp_path / "warp.jpg"], capfd)[0] == 0
    code, _, err = run_main([*argv, "--output", tmp_path / "black.png", "--background", "black"], capfd)
    assert code == 0, err
    assert (read_image(tmp_path / "black.png") == [0, 0, 0, 255]).all(axis=2).any()


@pytest.mark.parametrize("outside", ["transparent", "original"])
def test_the_viewers_still_export_of_a_large_picture_is_warps_file_byte_for_byte(
    tmp_path, capfd, monkeypatch, outside
):
    from app.render.renderer import WarpRenderer, create_headless_context

    # Every output counts as large: drawn and compressed strip by strip by both (issue 48 item 5).
    monkeypatch.setattr("app.warp.pipeline.STREAMED_PIXELS", 0)
    monkeypatch.setattr("app.render.renderer.STRIP_ROWS", 16)
    write_session(tmp_path, mesh={"max_edge": MAX_EDGE}, outside=outside)
    argv = ["warp", "--session", tmp_path / "session.json", "--output", tmp_path / "warp.png"]
    code, _, err = run_main(argv, capfd)
    assert code == 0, err

    state = viewer_state(Snapshot(tmp_path / "picture.png", CAGE_POINTS, MOVED), picture(), tmp_path)
    state.document.live = state.document.live.replace(outside=outside)
    ctx = create_headless_context()  # as warp's: its own, made after warp released its own
    try:
        with WarpRenderer(ctx) as renderer:
            scene = Scene(renderer)
            exporter = Exporter(state, scene, lambda s: True, None, 30.0, print, None)
            scene.sync(state)
            assert exporter.export(tmp_path / "viewer.png") == tmp_path / "viewer.png"
    finally:
        ctx.release()
    assert (tmp_path / "viewer.png").read_bytes() == (tmp_path / "warp.png").read_bytes()


@pytest.mark.parametrize("output", ["movie.gif", "frames/"])
def test_the_viewers_animation_export_is_animates_file_byte_for_byte_through_one_function(
    tmp_path, capfd, monkeypatch, output
):
    from app.render.renderer import WarpRenderer, create_headless_context

    callers = []
    original = app.warp.pipeline.write_frames

    def spy(renderer, deformation, targets, frame_output):
        callers.append((frame_output.kind, len(targets)))
        return original(renderer, deformation, targets, frame_output)

    monkeypatch.setattr(app.warp.pipeline, "write_frames", spy)
    monkeypatch.setattr("app.viewer.exports.EXPORT_BUDGET", 0.0)  # one step between two window frames
    keyed = [{"time": t, "target": {"control_points": p.tolist()}} for t, p in ((0, CAGE_POINTS), (1, MOVED))]
    write_session(tmp_path, mesh={"max_edge": MAX_EDGE}, keyframes=keyed)
    typed = str(tmp_path / "animate" / output)
    (tmp_path / "animate").mkdir()
    code, _, err = run_main(["animate", tmp_path / "session.json", "--output", typed, "--fps", "12"], capfd)
    assert code == 0, err
    kind = "gif" if output.endswith(".gif") else "png"
    assert callers == [(kind, 13)]

    state = keyframed_state(tmp_path)  # the session's own
    (tmp_path / "viewer").mkdir()
    ctx = create_headless_context()  # as animate's: its own, made after animate released its own
    try:
        with WarpRenderer(ctx) as renderer:
            scene = Scene(renderer)
            exporter = Exporter(state, scene, lambda s: True, None, 12.0, print, None)
            scene.sync(state)
            viewer = tmp_path / "viewer" / output
            exporter.export(viewer, str(viewer) + ("/" if kind == "png" else ""))
            steps = 0
            while exporter.animation is not None:
                exporter.next_frame()  # what the window does between its frames
                steps += 1
    finally:
        ctx.release()
    # A window frame after each frame drawn (and each of the GIF's 8 palette frames), and one to finish.
    assert callers == [(kind, 13), (kind, 13)] and steps == 13 + (8 if kind == "gif" else 0) + 1
    assert state.status.message == f"exported 13 frames to {viewer}"
    if kind == "gif":
        assert viewer.read_bytes() == (tmp_path / "animate" / output).read_bytes()
    else:
        names = sorted(path.name for path in viewer.iterdir())
        assert names == sorted(path.name for path in (tmp_path / "animate" / "frames").iterdir())
        for name in names:
            assert (viewer / name).read_bytes() == (tmp_path / "animate" / "frames" / name).read_bytes()


def keyframed_state(tmp_path):
    """The viewer's state of a picture keyframed at 0 s (the cage) and 1 s (moved), its basis computed."""
    from app.warp.keyframes import Keyframe

    write_png(tmp_path / "picture.png", picture())
    keyframes = (Keyframe(0.0, CAGE_POINTS), Keyframe(1.0, MOVED))
    snapshot = Snapshot(tmp_path / "picture.png", CAGE_POINTS, MOVED, keyframes=keyframes)
    return viewer_state(snapshot, picture(), tmp_path)


def exported(state, path, window_frames):
    """Ctrl+E to `path` in a viewer on its own GL context, then `window_frames` window frames; the
    exporter."""
    from app.render.renderer import WarpRenderer, create_headless_context

    ctx = create_headless_context()
    try:
        with WarpRenderer(ctx) as renderer:
            scene = Scene(renderer)
            exporter = Exporter(state, scene, lambda s: True, None, 12.0, print, None)
            scene.sync(state)
            exporter.export(path)
            for _ in range(window_frames):
                exporter.next_frame()
    finally:
        ctx.release()
    return exporter


def test_the_viewers_animation_export_meets_animates_gif_cap(tmp_path, monkeypatch):
    monkeypatch.setattr("app.warp.frame_writers.MAX_GIF_BYTES", 1000)
    state = keyframed_state(tmp_path)
    exporter = exported(state, tmp_path / "movie.gif", 0)
    assert exporter.animation is None and state.status.message_is_error
    message = state.status.message
    assert (
        message.startswith(f"{tmp_path / 'movie.gif'}: 13 frames of ")
        and " are too many for a GIF; " in message
    )
    assert sorted(path.name for path in tmp_path.iterdir()) == ["picture.png"]


def test_an_animation_export_stopped_midway_leaves_nothing(tmp_path, monkeypatch):
    monkeypatch.setattr("app.viewer.exports.EXPORT_BUDGET", 0.0)
    state = keyframed_state(tmp_path)
    exporter = exported(state, tmp_path / "movie.gif", 12)  # the 8 palette frames and 4 of the 13
    assert exporter.progress == 4 / 13
    assert exporter.cancel() and exporter.animation is None
    assert state.status.message == "animation export stopped; nothing was written"
    assert sorted(path.name for path in tmp_path.iterdir()) == ["picture.png"]
