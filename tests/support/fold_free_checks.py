"""What every fold-free warp on a mesh must give (`core.fold_free_deform` with its boundary and triangles)."""

from __future__ import annotations

import json

import numpy as np

import core
from support.paths import ROOT


def mesh_deformed(curve: core.ClosedBSpline, target: np.ndarray, mesh: core.Mesh):
    """`core.fold_free_deform` of the mesh's vertices onto `target` (n, 2), given the mesh's boundary
    and triangles.  Returns (images (V, 2), certificate), unchecked."""
    return core.fold_free_deform(
        curve,
        target,
        mesh.vertices,
        boundary=(mesh.boundary, mesh.boundary_parameters),
        triangles=mesh.triangles,
    )


def unfolded(curve: core.ClosedBSpline, target: np.ndarray, mesh: core.Mesh):
    """`mesh_deformed`, checked: no triangle turned over, the boundary vertices exactly on the target
    curve at their parameters, every interior vertex inside it.  Returns (images (V, 2), certificate)."""
    images, certificate = mesh_deformed(curve, target, mesh)
    assert np.count_nonzero(core.folded_triangles(mesh, images)) == 0 == certificate.extra["turned_over"]
    final = core.ClosedBSpline(target)
    np.testing.assert_array_equal(images[mesh.boundary], final(mesh.boundary_parameters))
    assert final.contains(images[mesh.interior]).all()
    return images, certificate


ASSETS = ROOT / "assets"


STARFISH = np.array(json.loads((ASSETS / "starfish.cage.json").read_text())["control_points"], dtype=float)


#: A strong drag of the starfish demo: a point beside an arm pulled 60 px up and left, across the
#: arm's root (the plain map folds: 15 triangles of this mesh, 249 at the viewer's default mesh).
STRONG = (5, 60.0 * np.array([np.cos(np.radians(225.0)), np.sin(np.radians(225.0))]))


def strong_target() -> np.ndarray:
    target = STARFISH.copy()
    target[STRONG[0]] += STRONG[1]
    return target
