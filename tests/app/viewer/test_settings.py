"""app.viewer.settings: the viewer's settings file, kept between runs."""

from __future__ import annotations

import json

import pytest

from app.viewer.settings import FILE_NAME, read_settings, settings_path, window_rectangle, write_settings


def test_the_file_is_in_the_state_directory(tmp_path, monkeypatch):
    monkeypatch.setenv("TRANSFINITE_STATE_DIR", str(tmp_path / "state"))
    assert settings_path() == tmp_path / "state" / FILE_NAME


def test_written_settings_are_read_back_and_merged(tmp_path):
    path = tmp_path / "new" / FILE_NAME
    assert read_settings(path) == {}
    write_settings({"window": {"x": 1, "y": 2, "width": 800, "height": 600}}, path)
    write_settings({"cage_drawing": "control"}, path)
    settings = read_settings(path)
    assert settings["cage_drawing"] == "control"
    assert window_rectangle(settings) == (1, 2, 800, 600)
    assert not list(path.parent.glob("*.tmp*"))  # written atomically: no temporary left


@pytest.mark.parametrize("text", ["{not json", "[1, 2]", '"a string"', ""])
def test_a_damaged_file_means_the_defaults(tmp_path, text):
    path = tmp_path / FILE_NAME
    path.write_text(text)
    assert read_settings(path) == {}
    write_settings({"cage_drawing": "curve"}, path)  # and is replaced by a good one
    assert json.loads(path.read_text()) == {"cage_drawing": "curve"}


@pytest.mark.parametrize(
    "window",
    [
        None,
        [0, 0, 800, 600],
        {"x": 0, "y": 0, "width": 800},
        {"x": 0, "y": 0, "width": -5, "height": 600},
        {"x": "0", "y": 0, "width": 800, "height": 600},
        {"x": float("nan"), "y": 0, "width": 800, "height": 600},
    ],
)
def test_a_damaged_window_entry_is_no_window(window):
    assert window_rectangle({"window": window}) is None
