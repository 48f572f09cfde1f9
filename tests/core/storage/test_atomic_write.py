"""Tests of core.storage.atomic_write: atomic replacement, stale temporaries, the umask."""

import os
import subprocess
import sys

import pytest

from core.storage.atomic_write import remove_stale_temporaries, temporary_path, write_atomically


@pytest.fixture(scope="module")
def dead_pid():
    """The id of a process that has exited."""
    process = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True)
    return int(process.stdout)


def test_temporaries_of_dead_processes_are_removed_by_the_next_write(tmp_path, dead_pid):
    target = tmp_path / "out.png"
    stale = tmp_path / f".out.png.{dead_pid}.0badc0de.tmp"
    live = tmp_path / f".out.png.{os.getppid()}.0badc0de.tmp"  # a writer still running
    other = tmp_path / f".other.png.{dead_pid}.0badc0de.tmp"  # another file's
    foreign = tmp_path / ".out.png.k2j3h4.tmp"  # not our naming
    for path in (stale, live, other, foreign):
        path.write_bytes(b"partial")
    write_atomically(target, lambda stream: stream.write(b"new"))
    assert target.read_bytes() == b"new"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        p.name for p in (target, live, other, foreign)
    )
    assert remove_stale_temporaries(tmp_path / "other.png") == [other]


@pytest.mark.parametrize(("umask", "mode"), [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_a_new_file_gets_the_mode_of_the_umask(tmp_path, umask, mode):
    previous = os.umask(umask)
    try:
        write_atomically(tmp_path / "new.bin", lambda stream: stream.write(b"x"))
    finally:
        os.umask(previous)
    assert (tmp_path / "new.bin").stat().st_mode & 0o777 == mode


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path):
    target = tmp_path / "data.bin"
    target.write_bytes(b"old")

    def fail(stream):
        stream.write(b"half")
        raise OSError(28, "No space left on device")

    with pytest.raises(OSError, match="No space left"):
        write_atomically(target, fail)
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["data.bin"]


@pytest.mark.parametrize("length", [245, 251, 255])
def test_names_up_to_255_bytes_are_written_through_a_shortened_temporary(tmp_path, dead_pid, length):
    target = tmp_path / ("é" * 2 + "n" * (length - 8) + ".png")  # two 2-byte characters
    assert len(os.fsencode(target.name)) == length
    temporary = temporary_path(target, ".mp4")
    assert len(os.fsencode(temporary.name)) <= 255
    # A stale temporary of the shortened name is found and removed, another name's is not.
    stale = temporary.with_name(temporary.name.replace(f".{os.getpid()}.", f".{dead_pid}."))
    other = temporary_path(tmp_path / ("n" * (length - 4) + ".png"))
    stale.write_bytes(b"partial")
    other.with_name(other.name.replace(f".{os.getpid()}.", f".{dead_pid}.")).write_bytes(b"partial")
    write_atomically(target, lambda stream: stream.write(b"new"))
    assert target.read_bytes() == b"new"
    assert not stale.exists()
    assert len(list(tmp_path.iterdir())) == 2
