"""Tests of app.io.bundled: the shipped folders in the source tree and in an installed package."""

import pytest
from support.paths import ROOT

from app.io import bundled
from app.io.bundled import FOLDERS, bundled_directory


@pytest.mark.parametrize("folder", FOLDERS)
def test_the_source_tree_uses_the_top_level_folders(folder):
    # Run from the source tree (or an editable install) there is no app/data.
    assert not (ROOT / "app" / "data").exists()
    assert bundled_directory(folder) == ROOT / folder


@pytest.mark.parametrize("folder", FOLDERS)
def test_an_installed_package_uses_its_package_data(folder, tmp_path, monkeypatch):
    installed = tmp_path / "site-packages" / "app"
    (installed / "data" / folder).mkdir(parents=True)
    monkeypatch.setattr(bundled, "files", lambda package: installed if package == "app" else None)
    assert bundled_directory(folder) == installed / "data" / folder


def test_unknown_folder():
    with pytest.raises(ValueError, match="unknown bundled folder 'fonts'; choose one of shaders, assets"):
        bundled_directory("fonts")
