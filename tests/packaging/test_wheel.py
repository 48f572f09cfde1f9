"""The built wheel, installed in a fresh virtual environment, works from anywhere.

The repository is copied to a temporary folder, packed there into a source distribution
(`.packaging/backend.py`), the copy is deleted and ``pip wheel`` builds from the sdist;
the wheel goes into a new venv that has only its dependencies (this environment's, linked), and
its commands run from an unrelated folder: ``fit``, ``warp``,
``compare`` and, under Xvfb, ``demo --frames``.  That proves the wheel ships every
package, the shaders and the demo assets, and that nothing reads the source tree.

It takes a minute or more (the build compiling the solver into the wheel, pip's isolated build),
so it runs only with ``TRANSFINITE_WHEEL_CHECK=1``, as ``.ci/run`` sets it.
``.ci/run`` also sets ``TRANSFINITE_PRECOMPILED`` (`.packaging/backend.py`): the build then
ships the cache that the run has just compiled in the source tree instead of compiling it again;
either way the installed wheel must load every compiled function without compiling.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
import tomllib
from support.paths import ROOT

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(
        os.environ.get("TRANSFINITE_WHEEL_CHECK") != "1",
        reason="slow: set TRANSFINITE_WHEEL_CHECK=1 (.ci/run does)",
    ),
]


def run(command: list, timeout: float, **kwargs) -> subprocess.CompletedProcess:
    """Run `command`; fail the test with its output if it exits non-zero."""
    result = subprocess.run(
        [str(part) for part in command], capture_output=True, text=True, timeout=timeout, **kwargs
    )
    assert result.returncode == 0, f"{command} failed:\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}"
    return result


@pytest.fixture(scope="module")
def venv(tmp_path_factory) -> Path:
    """A fresh venv with the wheel and its dependencies installed; the wheel's source is gone."""
    work = tmp_path_factory.mktemp("wheel")
    # Without a pip of its own (ensurepip: ~4 CPU-s): this environment's pip installs into it.
    run([sys.executable, "-m", "venv", "--without-pip", work / "venv"], 300)
    python = work / "venv" / "bin" / "python"
    # The dependencies (pyproject.toml's list, which the wheel's metadata repeats) are this
    # environment's, as pip resolved them for the project: their files linked into one folder that
    # the venv has on its path (a .pth line, which runs nothing), so that the wheel's install
    # resolves them from its metadata without unpacking ~650 MB again (~8 CPU-s) and the commands
    # below find their bytecode. Only they are there: not the project's editable install, nor the
    # test tools.
    dependencies = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    linked = work / "dependencies"
    link_distributions(linked, dependencies)
    (next((work / "venv" / "lib").glob("python3*")) / "site-packages" / "dependencies.pth").write_text(
        f"{linked}\n"
    )
    wheel = build_wheel(work)
    install = [sys.executable, "-m", "pip", "--python", python, "install", "--quiet", "--no-compile"]
    run([*install, wheel], 1200)
    return work / "venv"


def link_distributions(folder: Path, requirements: list[str]) -> None:
    """Link into `folder` the top-level files and folders (packages, modules, bundled libraries,
    metadata) of the installed distributions that `requirements` (list of str) need, and of theirs."""
    from importlib import metadata

    from packaging.requirements import Requirement
    from packaging.utils import canonicalize_name

    folder.mkdir()
    pending, seen = list(requirements), set()
    while pending:
        requirement = Requirement(pending.pop())
        name = canonicalize_name(requirement.name)
        if name in seen or (requirement.marker and not requirement.marker.evaluate({"extra": ""})):
            continue
        seen.add(name)
        distribution = metadata.distribution(name)
        tops = {file.parts[0] for file in distribution.files or ()} - {"..", "__pycache__"}
        assert tops, f"{name} lists no installed files"
        for top in tops:
            (folder / top).symlink_to(Path(distribution.locate_file(top)))
        pending += distribution.requires or []


def build_wheel(work: Path) -> Path:
    """The wheel built from the source distribution of a copy of the repository's tracked files,
    in work/dist; the copy is deleted before the build."""
    source = work / "source"
    tracked = run(["git", "ls-files", "-z"], 60, cwd=ROOT).stdout.split("\0")
    for name in filter(None, tracked):
        if (ROOT / name).is_file():
            (source / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, source / name)
    # Through the source distribution, as from a package index: it must carry the build backend.
    build = "import sys; sys.path.insert(0, '.packaging'); import backend; "
    build += f"print(backend.build_sdist({str(work)!r}))"
    sdist = work / run([sys.executable, "-c", build], 300, cwd=source).stdout.strip().splitlines()[-1]
    shutil.rmtree(source)
    run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "-w", work / "dist", sdist], 600)
    (wheel,) = (work / "dist").glob("transfinite_warp-*.whl")
    return wheel


@pytest.fixture
def elsewhere(tmp_path, venv) -> tuple[Path, dict]:
    """An unrelated working folder and an environment that can reach neither the source tree
    nor the user's caches and sessions."""
    environment = {
        key: value
        for key, value in os.environ.items()
        if key not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")
    }
    environment.update(
        PATH=f"{venv / 'bin'}{os.pathsep}{environment.get('PATH', '')}",
        XDG_CACHE_HOME=str(tmp_path / "cache"),
        XDG_STATE_HOME=str(tmp_path / "state"),
    )
    environment.pop("TRANSFINITE_CACHE_DIR", None)
    environment.pop("TRANSFINITE_STATE_DIR", None)
    folder = tmp_path / "elsewhere"
    folder.mkdir()
    return folder, environment


def picture() -> np.ndarray:
    """A 200 x 150 RGBA picture: a blue ellipse with a white spot on a transparent background."""
    image = np.zeros((150, 200, 4), np.uint8)
    cv2.ellipse(image, (100, 75), (70, 45), 0, 0, 360, (220, 120, 40, 255), -1, cv2.LINE_AA)
    cv2.circle(image, (80, 60), 12, (255, 255, 255, 255), -1)
    return image


def test_the_installed_wheel_runs_its_commands_from_anywhere(venv, elsewhere):
    folder, environment = elsewhere

    def command(*arguments, timeout=600):
        return run(arguments, timeout, cwd=folder, env=environment)

    # The build compiled core into the wheel (.packaging/backend.py): the first use of the Newton
    # solver and its gradients loads them, with numba's user-wide cache empty (XDG_CACHE_HOME).
    first_use = command(
        "python", "-c",
        "import app, app.viewer, core; print(app.__file__); print(core.__file__); "
        "print(core.compile_solver(gradients=True))",
    )  # fmt: skip
    *located, compiled = first_use.stdout.splitlines()
    assert len(located) == 2, first_use.stdout
    site_packages = next((venv / "lib").glob("python3*/site-packages"))
    for path in located:
        assert Path(path).is_relative_to(site_packages), f"imported {path}, not the installed wheel"
    assert compiled == "False", f"the installed wheel compiled:\n{first_use.stderr}"
    assert command("transfinite-warp", "--help").stdout.startswith("usage: transfinite-warp ")
    # The default kernel reads its compiled boundary integrals from numba's cache once a process
    # has evaluated LOAD_AFTER_POINTS points (compiled_integrals.loaded), never compiling them:
    # from the wheel they must be there, for the evaluation, the next density solve and what a
    # solve calls only beside thin parts (poisson.exercise_near_field).
    compiled_layer = command(
        "python", "-c",
        "import numpy as np, core; from core.boundary_integrals import compiled_integrals as c, poisson; "
        "from core.boundary_integrals.compiled_tree import layer_rows, target_boxes; "
        "square = core.ClosedBSpline(np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])); "
        "x = np.random.default_rng(1).uniform(0.3, 0.7, (c.LOAD_AFTER_POINTS + 1, 2)); "
        "core.basis_functions(square, x); poisson.solved_densities.cache_clear(); "
        "core.basis_functions(square, x[:1]); "
        "from core.boundary_integrals.panels import curve_panels; "
        "poisson.exercise_near_field(square, curve_panels(square)); "
        "print(*(len(f.overloads) for f in "
        "(c.adaptive_pairs, layer_rows, target_boxes, c.layer_matrix_rows, c.knot_blocks, c.coarse_system, "
        "c.panel_geometry, c.panel_gaps, c.close_pairs, c.galerkin_matrix, c.rows_product, "
        "c.interpolation_rows)))",
    )  # fmt: skip
    assert compiled_layer.stdout.split() == ["1"] * 12, f"not loaded:\n{compiled_layer.stderr}"

    cv2.imwrite(str(folder / "blob.png"), picture())
    command("transfinite-warp", "fit", "blob.png", "--output", "cage.json", "--points", "10")
    cage = json.loads((folder / "cage.json").read_text())["control_points"]
    target = [[x + 0.1 * (y - 75), y] for x, y in cage]  # a shear
    (folder / "target.json").write_text(json.dumps({"control_points": target}))
    command(
        "transfinite-warp",
        "warp",
        "blob.png",
        "--cage",
        "cage.json",
        "--target",
        "target.json",
        "--output",
        "out.png",
    )
    warped = cv2.imread(str(folder / "out.png"), cv2.IMREAD_UNCHANGED)
    assert warped.shape == (150, 200, 4) and warped[..., 3].any()

    table = command(
        "python", "-m", "app", "compare", "--cage", "cage.json", "--output", "compare.png",
        "--kernel", "mean-value", "--max-edge", "8",
    ).stdout  # fmt: skip
    assert table.splitlines()[1].startswith("harmonic ") and (folder / "compare.png").is_file()


def test_the_installed_wheel_replays_a_demo_under_xvfb(venv, elsewhere):
    from support.viewer_harness import start_xvfb

    folder, environment = elsewhere
    server, display = start_xvfb()
    try:
        run(
            ["transfinite-warp", "demo", "pattern", "--frames", "frames", "--fps", "4"],
            600,
            cwd=folder,
            env={**environment, "DISPLAY": display},
        )
    finally:
        server.terminate()
        server.wait()
    frames = sorted((folder / "frames").glob("frame_*.png"))
    assert len(frames) > 4
    assert not (folder / "cache" / "transfinite-warp" / "demos").exists(), "the shipped demo assets are used"
    first, last = (cv2.imread(str(frame)) for frame in (frames[0], frames[-1]))
    assert first.shape == last.shape and not np.array_equal(first, last), "the replay moved the cage"
