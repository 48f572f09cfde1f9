"""app.viewer.file_browser: the viewer's own file list where no dialog program is installed."""

import os

from app.viewer.file_browser import (
    MAX_ENTRIES,
    OPEN_SUFFIXES,
    chosen,
    current_listing,
    folder_of,
    listing,
)


def make_folder(root):
    (root / "photos").mkdir()
    (root / "Sessions").mkdir()
    (root / ".hidden").mkdir()
    for name in ("b.PNG", "a.svg", "cage.json", "notes.txt", ".secret.png"):
        (root / name).write_text("x")
    return root


def test_folders_first_then_the_files_that_open_by_name_hidden_ones_left_out(tmp_path):
    listed = listing(str(make_folder(tmp_path)) + os.sep, OPEN_SUFFIXES)
    assert listed.folder == tmp_path.resolve() and listed.note == ""
    names = [entry.name for entry in listed.entries]
    assert names == ["..", f"photos{os.sep}", f"Sessions{os.sep}", "a.svg", "b.PNG", "cage.json"]
    assert [entry.folder for entry in listed.entries] == [True, True, True, False, False, False]


def test_the_folder_of_a_typed_path_is_the_nearest_that_exists(tmp_path):
    make_folder(tmp_path)
    assert folder_of(str(tmp_path / "photos")) == (tmp_path / "photos").resolve()
    assert folder_of(str(tmp_path / "a.s")) == tmp_path.resolve()  # a name half typed
    assert folder_of(str(tmp_path / "gone" / "deeper" / "x.png")) == tmp_path.resolve()
    assert folder_of("") == folder_of("~")


def test_a_click_goes_into_a_folder_or_takes_the_file(tmp_path):
    listed = listing(str(make_folder(tmp_path)) + os.sep, OPEN_SUFFIXES)
    up, photos = listed.entries[0], listed.entries[1]
    assert chosen(up) == str(tmp_path.resolve().parent) + os.sep
    assert chosen(photos) == str(tmp_path.resolve() / "photos") + os.sep
    assert chosen(listed.entries[3]) == str(tmp_path.resolve() / "a.svg")


def test_a_huge_folder_is_cut_and_read_again_only_when_it_changes(tmp_path):
    many = tmp_path / "many"
    many.mkdir()
    for index in range(MAX_ENTRIES + 5):
        (many / f"{index:05d}.png").touch()
    listed = current_listing(str(many) + os.sep, OPEN_SUFFIXES)
    assert (
        len(listed.entries) == MAX_ENTRIES + 1
        and listed.note == f"the first {MAX_ENTRIES} of {MAX_ENTRIES + 5}"
    )
    assert current_listing(str(many / "00001.png"), OPEN_SUFFIXES) is listed  # read once while unchanged
    (many / "new.png").touch()
    assert current_listing(str(many) + os.sep, OPEN_SUFFIXES) is not listed
