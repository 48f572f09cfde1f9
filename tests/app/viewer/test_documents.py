"""Opening and saving viewer documents (app.viewer.documents)."""

import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest

from app.io.files import InputError, kernel_names
from app.io.session import read_session
from app.render.viewport import View
from app.viewer import documents as sessions
from app.viewer.demos import demo_files
from app.viewer.session_files import BACKUPS, backup_path, backups, session_path_for
from app.viewer.state import AppState, Display, Document, History, Pins
from app.warp.pins import session_pins


@pytest.fixture(autouse=True)
def state_directory(tmp_path, monkeypatch):
    monkeypatch.setenv("TRANSFINITE_STATE_DIR", str(tmp_path / "state"))


def test_every_image_has_its_own_session_file_whatever_the_command(tmp_path, monkeypatch):
    folder = tmp_path / "pictures"
    (folder / "other").mkdir(parents=True)
    monkeypatch.chdir(folder)
    path = session_path_for(Path("my image.png"))
    assert path.parent == tmp_path / "state" / "sessions" and path.name.startswith("my_image-")
    assert session_path_for(folder / "other" / ".." / "my image.png") == path  # the same file
    assert session_path_for(folder / "other" / "my image.png") != path  # same name, another picture
    # The bare viewer, `view IMAGE --cage` and `demo` open the demo's image: one session file.
    files = demo_files("starfish")
    demo = sessions.open_document()
    assert demo.session_path == session_path_for(files.image)
    assert sessions.open_document(files.image, files.cage).session_path == demo.session_path
    assert sessions.open_document(demo_name="starfish").session_path == demo.session_path
    assert sessions.open_document(demo_name="pattern").session_path != demo.session_path


def test_open_a_demo_an_image_and_fit(tmp_path):
    document = sessions.open_document()
    assert document.snapshot.image.name == "starfish.png" and document.view is None
    assert np.array_equal(document.snapshot.cage, document.snapshot.target)
    assert not document.restored and not document.undo and not document.notices
    files = demo_files("pattern")
    fitted = sessions.open_document(files.image)  # no cage: fitted to the silhouette
    assert 10 <= fitted.snapshot.n <= 16
    blank = tmp_path / "blank.png"
    from app.io.files import write_png

    write_png(blank, np.full((12, 10, 4), 255, np.uint8))
    document = sessions.open_document(blank)  # nothing to fit with 16 points: an ellipse
    assert document.snapshot.n == 12
    note = sessions.fit_or_ellipse(np.full((12, 10, 4), 255, np.uint8))[1]
    assert note.startswith("no subject found")


def test_save_and_restore_everything(tmp_path):
    files = demo_files("starfish")
    path = tmp_path / "s.json"
    document = sessions.open_document(files.image, files.cage, path)
    snapshot = document.snapshot.replace(kernel="power", power=3.0, shift="none")
    target = snapshot.target.copy()
    target[2] += [12, -4]
    snapshot = snapshot.replace(target=target)
    state = AppState(
        Document(History(snapshot), snapshot, document.image, path),
        display=Display(viewport=View(1.25, (310.0, 7.5))),
    )
    state.selection.edit_mode, state.display.view_mode, state.selection.selected = "cage", "height", 2
    sessions.save(state, 2.5)
    stored = json.loads(path.read_text())
    assert stored["kernel_params"] == {"power": 3.0, "shift": "none"}
    assert stored["mesh"] == {"max_edge": 2.5}
    assert stored["image"] == str(Path("..") / "..") or stored["image"].endswith("starfish.png")
    restored = sessions.restore(path)
    assert restored.snapshot == snapshot and restored.view == View(1.25, (310.0, 7.5))
    assert restored.max_edge == 2.5
    again = AppState(Document(History(restored.snapshot), restored.snapshot, restored.image, path))
    sessions.apply_preferences(again, restored.preferences)
    assert (again.selection.edit_mode, again.display.view_mode, again.selection.selected) == (
        "cage",
        "height",
        2,
    )
    with pytest.raises(InputError, match="exists: open it alone with --session"):
        sessions.open_document(files.image, None, path)
    broken = path.with_name("broken.json")
    broken.write_text("{ not json")
    with pytest.raises(InputError, match=r"broken.json exists but cannot be read \(not valid JSON"):
        sessions.open_document(files.image, None, broken)


def test_pins_their_bound_and_the_fixed_points_are_saved_and_restored_with_their_history(tmp_path):
    files = demo_files("starfish")
    path = tmp_path / "p.json"
    document = sessions.open_document(files.image, files.cage, path)
    first = document.snapshot.replace(pins=Pins((((300.0, 250.0), (300.0, 250.0)),)))
    target = first.target.copy()
    target[3] += [5.0, -2.0]
    second = first.replace(pins=Pins((((300.0, 250.0), (310.0, 240.0)),), 2.5, (3,)), target=target)
    history = History(document.snapshot)
    history.push(first)
    history.push(second)
    state = AppState(Document(history, second, document.image, path))
    state.selection.edit_mode = "pins"
    sessions.save(state, None)
    stored = json.loads(path.read_text())
    assert stored["pins"] == [{"at": [300.0, 250.0], "to": [310.0, 240.0]}]
    assert stored["max_distortion"] == 2.5 and stored["fixed"] == [3]
    # `warp --session` reads the very pins, bound and held point.
    request = session_pins(read_session(path), path)
    np.testing.assert_array_equal(request.moved, [[310.0, 240.0]])
    assert request.max_distortion == 2.5 and list(request.fixed) == [3]
    restored = sessions.restore(path)
    assert restored.snapshot == second and restored.undo == [document.snapshot, first]
    again = AppState(Document(History(restored.snapshot), restored.snapshot, restored.image, path))
    sessions.apply_preferences(again, restored.preferences)
    assert again.selection.edit_mode == "pins"


def test_a_saved_session_reads_back_with_the_shared_reader(tmp_path):
    files = demo_files("character")
    path = tmp_path / "c.json"
    document = sessions.open_document(files.image, files.cage, path)
    state = AppState(Document(History(document.snapshot), document.snapshot, document.image, path))
    sessions.save(state, None)
    session = read_session(path)
    assert session.image.resolve() == files.image.resolve() and session.kernel.name == "poisson"
    assert session.max_edge is None and session.kernel.params == {}


def test_a_session_keeps_the_kernel_it_names_whatever_the_default(tmp_path):
    # The default changed from harmonic-like to harmonic (README, "Which kernel?"): an older
    # session that names harmonic-like must reopen with it.
    files = demo_files("character")
    path = tmp_path / "c.json"
    document = sessions.open_document(files.image, files.cage, path)
    snapshot = dataclasses.replace(document.snapshot, kernel="harmonic-like")
    sessions.save(AppState(Document(History(snapshot), snapshot, document.image, path)), None)
    reopened = sessions.open_document(session=path)
    assert reopened.snapshot.kernel == "harmonic-like"


@pytest.mark.parametrize("kernel", kernel_names())
def test_an_edit_is_saved_and_restored_with_every_kernel(tmp_path, kernel):
    files = demo_files("character")
    path = tmp_path / "c.json"
    document = sessions.open_document(files.image, files.cage, path)
    snapshot = dataclasses.replace(document.snapshot, kernel=kernel)
    state = AppState(Document(History(snapshot), snapshot, document.image, path))
    edited(state, 7)
    sessions.save(state, None)
    document.lock.release()
    reopened = sessions.open_document(session=path)
    assert reopened.snapshot.kernel == kernel
    np.testing.assert_array_equal(reopened.snapshot.target, state.document.live.target)
    assert not np.array_equal(reopened.snapshot.target, reopened.snapshot.cage)


def edited(state: AppState, step: int) -> None:
    """Move control point 0 of the target by (step, -step): one undoable edit."""
    target = state.document.live.target.copy()
    target[0] += [step, -step]
    snapshot = state.document.live.replace(target=target)
    state.document.history.push(snapshot)
    state.document.live = snapshot


def opened_state(document) -> AppState:
    history = History(document.snapshot, undo=document.undo, redo=document.redo)
    return AppState(Document(history, document.snapshot, document.image, document.session_path))


def test_reopening_an_image_restores_its_state_and_undo_history():
    files = demo_files("starfish")
    first = sessions.open_document(files.image, files.cage)
    state = opened_state(first)
    for step in (1, 2, 3):
        edited(state, step)
    state.document.history.undo()  # one step to redo
    state.document.live = state.document.history.current
    state = replace_kernel(state, "pseudo-harmonic")
    sessions.save(state, None)
    again = sessions.open_document(files.image, files.cage)  # the same command once more
    assert again.restored and again.session_path == first.session_path
    assert again.snapshot == state.document.history.current
    assert again.undo == list(state.document.history.undo_steps) and again.redo == list(
        state.document.history.redo_steps
    )
    assert len(again.undo) == 3 and len(again.redo) == 0  # the kernel change dropped the redo step
    assert again.notices[-1].startswith("restored starfish.png from the session (3 undo steps)")
    history = opened_state(again).document.history
    assert history.undo().kernel == "poisson" and history.undo() == again.undo[1]
    assert sessions.open_document().snapshot == state.document.history.current  # the bare viewer too


def replace_kernel(state: AppState, kernel: str) -> AppState:
    snapshot = state.document.live.replace(kernel=kernel)
    state.document.history.push(snapshot)
    state.document.live = snapshot
    return state


def test_the_saved_history_is_bounded_and_in_order():
    files = demo_files("starfish")
    state = opened_state(sessions.open_document(files.image, files.cage))
    for step in range(sessions.SAVED_STEPS + 20):
        edited(state, step)
    for _ in range(5):
        state.document.history.undo()
    sessions.save(state, None)
    restored = sessions.restore(state.document.session_path)
    assert restored.undo == list(state.document.history.undo_steps[-sessions.SAVED_STEPS :])
    assert restored.redo == list(state.document.history.redo_steps) and len(restored.redo) == 5
    text = state.document.session_path.read_text()
    assert not re.search(r"^\s*-?[0-9][0-9.eE+-]*,?$", text, re.MULTILINE)  # no number alone on a line
    assert text.count("[[") == 0 and text.count("\n") > 2 * len(restored.undo)  # but a pair a line


def test_a_damaged_history_is_dropped_but_the_state_restored(tmp_path):
    files = demo_files("starfish")
    state = opened_state(sessions.open_document(files.image, files.cage))
    edited(state, 4)
    sessions.save(state, None)
    value = json.loads(state.document.session_path.read_text())
    value["history"]["undo"][0]["kernel"] = "no-such-kernel"
    state.document.session_path.write_text(json.dumps(value))
    restored = sessions.open_document(files.image, files.cage)
    assert restored.snapshot == state.document.history.current and restored.undo == []
    assert (
        "the undo history cannot be read" in restored.notices[0] and "no-such-kernel" in restored.notices[0]
    )


def test_autosave_keeps_the_last_versions_and_view_changes_do_not_rotate():
    files = demo_files("starfish")
    state = opened_state(sessions.open_document(files.image, files.cage))
    path = state.document.session_path
    sessions.save(state, None)
    versions = [path.read_bytes()]
    for step in range(1, BACKUPS + 3):
        edited(state, step)
        sessions.save(state, None)
        versions.append(path.read_bytes())
    state.display.viewport = View(2.0, (5.0, 6.0))
    sessions.save(state, None, new_version=False)  # a zoom: the same version, no rotation
    assert backups(path) == [backup_path(path, k) for k in range(1, BACKUPS + 1)]
    for k in range(1, BACKUPS + 1):
        assert backup_path(path, k).read_bytes() == versions[-1 - k]
    assert json.loads(path.read_text())["view"]["scale"] == 2.0
    assert not list(path.parent.glob(".*.tmp"))


@pytest.mark.parametrize("damage", [b"{ not json", b'{"image": "x.png"}', b""])
def test_an_unreadable_session_is_kept_aside_and_the_newest_backup_restored(damage):
    files = demo_files("starfish")
    state = opened_state(sessions.open_document(files.image, files.cage))
    path = state.document.session_path
    edited(state, 7)
    sessions.save(state, None)
    good = state.document.history.current
    edited(state, 8)
    sessions.save(state, None)  # the version with 7 is backup 1 now
    path.write_bytes(damage)
    document = sessions.open_document(files.image, files.cage)
    (aside,) = path.parent.glob(f"{path.stem}.unreadable-*.json")
    assert aside.read_bytes() == damage  # kept, byte for byte
    assert document.snapshot == good and document.session_path == path and not path.exists()
    assert "cannot restore the session" in document.notices[0] and str(aside) in document.notices[0]
    assert "from its backup" in document.notices[1]


def test_nothing_readable_starts_afresh_and_keeps_the_bad_file():
    files = demo_files("starfish")
    path = session_path_for(files.image)
    path.parent.mkdir(parents=True)
    path.write_text('{"image": "elsewhere.png", "cage": 1}')
    document = sessions.open_document(files.image, files.cage)
    assert not document.restored and np.array_equal(document.snapshot.cage, document.snapshot.target)
    assert len(list(path.parent.glob("*.unreadable-*.json"))) == 1 and not path.exists()


def test_another_images_session_under_this_name_is_not_taken():
    files, other = demo_files("starfish"), demo_files("pattern")
    state = opened_state(sessions.open_document(other.image, other.cage))
    state.document.session_path = session_path_for(files.image)  # as if the names collided
    sessions.save(state, None)
    document = sessions.open_document(files.image, files.cage)
    assert document.snapshot.image == files.image.resolve() and not document.restored
    assert "is the session of" in document.notices[0]


def test_fresh_starts_over_and_keeps_the_old_session():
    files = demo_files("starfish")
    state = opened_state(sessions.open_document(files.image, files.cage))
    edited(state, 5)
    sessions.save(state, None)
    before = state.document.session_path.read_bytes()
    fresh = sessions.open_document(files.image, files.cage, fresh=True)
    assert not fresh.restored and not fresh.undo and not state.document.session_path.exists()
    (aside,) = state.document.session_path.parent.glob("*.replaced-*.json")
    assert aside.read_bytes() == before and str(aside) in fresh.notices[0]
    with pytest.raises(InputError, match="--fresh"):
        sessions.open_document(session=aside, fresh=True)


def test_start_over_and_begin_with_are_one_undoable_step():
    files = demo_files("starfish")
    document = sessions.open_document(files.image, files.cage)
    state = opened_state(document)
    edited(state, 9)
    sessions.save(state, None)
    document = sessions.open_document(files.image, files.cage)
    start, note = sessions.start_snapshot(document.snapshot, document.image, files.cage)
    assert np.array_equal(start.target, start.cage) and note == "the cage of starfish.cage.json"
    restored = document.snapshot
    sessions.begin_with(document, start, "replay")
    assert document.snapshot == start and document.undo[-1] == restored and not document.restored
    count = len(document.undo)
    sessions.begin_with(document, start, "again")  # nothing changes: no step
    assert len(document.undo) == count and document.notices[-1] == "replay"


def test_keyframes_are_saved_restored_and_in_the_history_steps(tmp_path):
    from app.warp.keyframes import Keyframe

    files = demo_files("starfish")
    path = tmp_path / "k.json"
    document = sessions.open_document(files.image, files.cage, path)
    cage = document.snapshot.cage
    moved = cage + [5.0, -3.0]
    first = document.snapshot.replace(keyframes=(Keyframe(0.0, cage),))
    second = first.replace(keyframes=(*first.keyframes, Keyframe(1.5, moved)), interpolation="linear")
    state = AppState(Document(History(first), first, document.image, path))
    state.document.history.push(second)
    state.document.live, state.playback.time, state.playback.loop = second, 0.8, False
    sessions.save(state, None)
    stored = json.loads(path.read_text())
    assert [k["time"] for k in stored["keyframes"]] == [0.0, 1.5] and stored["interpolation"] == "linear"
    assert stored["keyframes"][1]["target"]["control_points"] == moved.tolist()
    assert len(stored["history"]["undo"][0]["keyframes"]) == 1  # the step before the second keyframe
    restored = sessions.restore(path)
    assert restored.snapshot == second and restored.undo == [first]
    again = AppState(Document(History(restored.snapshot), restored.snapshot, restored.image, path))
    sessions.apply_preferences(again, restored.preferences)
    assert (again.playback.time, again.playback.loop) == (0.8, False)


def test_old_sessions_without_keyframes_still_load(tmp_path):
    files = demo_files("starfish")
    path = tmp_path / "old.json"
    document = sessions.open_document(files.image, files.cage, path)
    state = opened_state(document)
    edited(state, 4)
    sessions.save(state, None)
    stored = json.loads(path.read_text())
    # What a session of the version before keyframes held: no keys for them, steps without them.
    for key in ("keyframes", "interpolation"):
        del stored[key]
        for step in stored["history"]["undo"]:
            del step[key]
    del stored["viewer"]["time"], stored["viewer"]["loop"]
    path.write_text(json.dumps(stored))
    restored = sessions.restore(path)
    assert restored.snapshot.keyframes == () and restored.snapshot.interpolation == "catmull-rom"
    assert len(restored.undo) == 1 and restored.undo[0].keyframes == ()
    assert restored.snapshot == state.document.live


def _hold_lock(session: Path, state: Path):
    """A process that locks `session` as a viewer would, and says so once it holds it."""
    import os
    import subprocess
    import sys

    code = (
        "import sys, time; from pathlib import Path; from app.viewer.session_lock import lock_session; "
        "lock = lock_session(Path(sys.argv[1])); print('held', flush=True); time.sleep(120)"
    )
    environment = dict(os.environ, TRANSFINITE_STATE_DIR=str(state))
    holder = subprocess.Popen(
        [sys.executable, "-c", code, str(session)], stdout=subprocess.PIPE, text=True, env=environment
    )
    assert holder.stdout.readline().strip() == "held"
    return holder


def test_a_second_viewer_of_the_same_image_is_refused_until_the_first_is_gone(tmp_path):
    import os
    import subprocess
    import sys

    from app.viewer.session_lock import SessionBusy

    files = demo_files("starfish")
    document = sessions.open_document(files.image, files.cage)
    assert sessions.open_document(files.image, files.cage).lock is document.lock  # this process: shared
    sessions.save(opened_state(document), None)
    written = document.session_path.read_bytes()
    document.lock.release()
    del document
    holder = _hold_lock(session_path_for(files.image), tmp_path / "state")
    try:
        with pytest.raises(SessionBusy, match=rf"open in another viewer \(process {holder.pid}\).*--session"):
            sessions.open_document(files.image, files.cage)
        with pytest.raises(SessionBusy):
            sessions.open_document(files.image, files.cage, fresh=True)  # --fresh must not rename it either
        environment = {**os.environ, "TRANSFINITE_STATE_DIR": str(tmp_path / "state")}
        result = subprocess.run(
            [sys.executable, "-m", "app", "view", str(files.image), "--cage", str(files.cage)],
            capture_output=True,
            text=True,
            env=environment,
            timeout=120,
        )
        assert result.returncode == 2
        assert result.stderr.strip().count("\n") == 0 and "open in another viewer" in result.stderr
        assert session_path_for(files.image).read_bytes() == written  # untouched, nothing kept aside
        assert sorted(p.name for p in session_path_for(files.image).parent.iterdir()) == [
            session_path_for(files.image).name
        ]
    finally:
        holder.kill()  # as kill -9: the operating system drops the lock
        holder.wait()
    reopened = sessions.open_document(files.image, files.cage)
    assert reopened.restored and reopened.lock is not None


def test_a_process_forked_from_the_viewer_does_not_keep_its_session_locked(tmp_path):
    # The precompute worker is forked from the viewer (app.viewer.precompute.start_method): its
    # copy of the lock file must not keep the session locked once the viewer is gone.
    import fcntl
    import os
    import time

    from app.viewer.session_lock import lock_file_for

    files = demo_files("starfish")
    document = sessions.open_document(files.image, files.cage)
    started, started_writer = os.pipe()
    child = os.fork()
    if child == 0:  # the fork handlers have run: say so, then live on as a worker would
        os.write(started_writer, b"1")
        time.sleep(30)
        os._exit(0)
    try:
        assert os.read(started, 1) == b"1"
        document.lock.release()
        descriptor = os.open(lock_file_for(document.session_path), os.O_RDWR)
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)  # BlockingIOError if the child held it
        finally:
            os.close(descriptor)
    finally:
        os.kill(child, 9)
        os.waitpid(child, 0)
        os.close(started)
        os.close(started_writer)


def _dead_pid() -> int:
    import subprocess
    import sys

    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


@pytest.mark.parametrize("given", ["image", "--session"])
def test_an_autosave_killed_before_its_rename_is_finished_on_the_next_open(given):
    """kill -9 between an autosave's write and its rename left the newest state in a temporary
    file: the next open takes it (the old file becomes backup 1), not a partial one, not one of a
    viewer still running, and not one older than the session."""
    import os

    files = demo_files("starfish")
    state = opened_state(sessions.open_document(files.image, files.cage))
    path = state.document.session_path
    edited(state, 1)
    sessions.save(state, None)
    saved = path.read_bytes()
    edited(state, 2)
    newest = state.document.history.current
    interrupted = path.parent / f".{path.name}.{_dead_pid()}.0123abcd.tmp"
    sessions.write_session(interrupted, sessions.session_of(state, None))
    edited(state, 3)
    running = path.parent / f".{path.name}.{os.getpid()}.00000000.tmp"  # this process is running
    sessions.write_session(running, sessions.session_of(state, None))
    partial = path.parent / f".{path.name}.{_dead_pid()}.89abcdef.tmp"
    partial.write_bytes(running.read_bytes()[:-40])  # killed while writing
    stamp = path.stat().st_mtime
    for offset, file in ((1, interrupted), (2, partial), (3, running)):
        os.utime(file, (stamp + offset, stamp + offset))
    if given == "image":
        document = sessions.open_document(files.image, files.cage)
    else:
        document = sessions.open_document(session=path)
    assert document.snapshot == newest
    assert "finished the last autosave" in document.notices[0]
    assert backup_path(path, 1).read_bytes() == saved
    assert not interrupted.exists() and partial.exists() and running.exists()
    # Once finished, an older leftover is not taken again.
    edited(state, 4)
    sessions.save(state, None)
    current = path.read_bytes()
    stale = path.parent / f".{path.name}.{_dead_pid()}.fedcba98.tmp"
    stale.write_bytes(saved)
    os.utime(stale, (stamp - 10, stamp - 10))
    again = sessions.open_document(session=path)
    assert path.read_bytes() == current and not any("finished" in n for n in again.notices)


def test_the_output_choices_come_back_in_every_undo_step_after_a_restart(tmp_path):
    """They are the snapshots' (undo steps) in the viewer, and the file's steps hold them: after a
    restart each undo step comes back with its own (an older session's steps take the session's)."""
    from app.viewer import commands

    files = demo_files("starfish")
    path = tmp_path / "settings.json"
    state = opened_state(sessions.open_document(files.image, files.cage, path))
    commands.command(state, "outside", "original")
    commands.command(state, "fill", "#20c040")
    sessions.save(state, None)
    stored = json.loads(path.read_text())
    assert (stored["outside"], stored["fill"]) == ("original", "#20c040")
    restored = sessions.restore(path)
    again = opened_state(restored)
    sessions.apply_preferences(again, restored.preferences)
    assert (again.document.outside, again.document.fill) == ("original", "#20c040")
    assert again.document.history.current == again.document.live
    undo = again.document.history.undo_steps
    assert [(s.outside, s.fill) for s in undo] == [("transparent", "none"), ("original", "none")]


def test_a_fitted_svg_cage_says_so_when_the_viewer_opens(tmp_path):
    files = demo_files("starfish")
    circle = tmp_path / "circle.svg"
    circle.write_text('<svg xmlns="http://www.w3.org/2000/svg"><circle cx="320" cy="240" r="150"/></svg>')
    document = sessions.open_document(files.image, circle, tmp_path / "s.json")
    assert document.notices[-1].startswith(f"{circle}: the path is not a quadratic B-spline; fitted ")
    radii = np.linalg.norm(document.snapshot.cage - [320, 240], axis=1)
    assert radii.min() > 140 and radii.max() < 170  # control points just outside the circle they fit
