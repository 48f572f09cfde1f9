"""The source distribution carries what a build from it needs: the build backend that
`pyproject.toml` names (``backend-path = [".packaging"]``), the packages, the shaders and
the demo assets.  setuptools alone left the backend out, so ``pip install`` of the sdist
failed with "No module named 'backend'"."""

from __future__ import annotations

import shutil
import subprocess
import sys
import tarfile

import pytest
import tomllib
from support.paths import ROOT

pytestmark = pytest.mark.slow


def test_the_source_distribution_carries_the_build_backend(tmp_path):
    source = tmp_path / "source"
    tracked = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, text=True, check=True)
    for name in filter(None, tracked.stdout.split("\0")):
        if (ROOT / name).is_file():
            (source / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, source / name)
    build = (
        "import sys; sys.path.insert(0, '.packaging'); import backend; "
        f"print(backend.build_sdist({str(tmp_path / 'dist')!r}))"
    )
    result = subprocess.run(
        [sys.executable, "-c", build], cwd=source, capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stderr[-3000:]
    name = result.stdout.strip().splitlines()[-1]
    root = name[: -len(".tar.gz")]
    with tarfile.open(tmp_path / "dist" / name) as archive:
        names = set(archive.getnames())
        backend = archive.extractfile(f"{root}/.packaging/backend.py").read()
    assert backend == (ROOT / ".packaging" / "backend.py").read_bytes()
    needed_files = (
        "pyproject.toml",
        "README.md",
        "core/boundary_integrals/poisson.py",
        "app/__main__.py",
        "shaders/mesh.vert.glsl",
    )
    for needed in needed_files:
        assert f"{root}/{needed}" in names, needed
    assert any(n.startswith(f"{root}/assets/") and n.endswith(".session.json") for n in names)


def test_a_build_that_compiles_asks_for_what_core_imports_at_the_package_s_versions(monkeypatch):
    sys.path.insert(0, str(ROOT / ".packaging"))
    try:
        import backend
    finally:
        sys.path.remove(str(ROOT / ".packaging"))
    dependencies = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    assert set(backend.COMPILE_REQUIRES) <= set(dependencies)
    monkeypatch.chdir(ROOT)  # setuptools' hooks read the pyproject.toml of the working folder
    monkeypatch.delenv("TRANSFINITE_PRECOMPILED", raising=False)
    monkeypatch.setenv("TRANSFINITE_PRECOMPILE", "1")
    assert set(backend.COMPILE_REQUIRES) <= set(backend.get_requires_for_build_wheel())
    # Without the compilation (an editable install for the tests, a wheel of a compiled cache),
    # the build environment needs setuptools alone.
    for name, value in (("TRANSFINITE_PRECOMPILE", "0"), ("TRANSFINITE_PRECOMPILED", "/compiled")):
        monkeypatch.setenv(name, value)
        assert not set(backend.COMPILE_REQUIRES) & set(backend.get_requires_for_build_editable())
        assert not set(backend.COMPILE_REQUIRES) & set(backend.get_requires_for_build_wheel())
