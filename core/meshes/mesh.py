"""A triangle mesh of a B-spline domain (`Mesh`) and what is asked of any mesh: its edges, the
signed areas of its triangles, the triangles a deformation folds over, whether it was made for
a curve.  Made by `core.triangulate` (`core.meshes.triangulation`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.curves.bspline import ClosedBSpline
from core.validation import as_points, positive_float


@dataclass(frozen=True, eq=False)
class Mesh:
    """A triangle mesh of a B-spline domain.

    Attributes
    ----------
    vertices : ndarray of shape (V, 2)
        float64 (x, y) positions.
    triangles : ndarray of shape (T, 3)
        int64 vertex indices, counter-clockwise in a y-up frame
        (``cross(b - a, c - a) > 0``).
    boundary : ndarray of shape (B,)
        int64 indices of the vertices on the curve, in increasing parameter order.
    boundary_parameters : ndarray of shape (B,)
        float64 parameters t in [0, n) with ``vertices[boundary] == curve(t)``.
    """

    vertices: np.ndarray
    triangles: np.ndarray
    boundary: np.ndarray
    boundary_parameters: np.ndarray

    def __post_init__(self):
        vertices = as_points(self.vertices, "vertices", min_count=3)
        triangles = np.array(self.triangles, dtype=np.int64)
        boundary = np.array(self.boundary, dtype=np.int64).reshape(-1)
        parameters = np.array(self.boundary_parameters, dtype=np.float64).reshape(-1)
        if triangles.ndim != 2 or triangles.shape[1] != 3 or triangles.shape[0] == 0:
            raise ValueError(f"triangles must have shape (T, 3) with T >= 1, got {triangles.shape}")
        if triangles.min() < 0 or triangles.max() >= vertices.shape[0]:
            raise ValueError(f"triangles must index vertices 0..{vertices.shape[0] - 1}")
        if boundary.shape != parameters.shape:
            raise ValueError(
                f"boundary and boundary_parameters must have the same length, got "
                f"{boundary.shape[0]} and {parameters.shape[0]}"
            )
        if boundary.size and (boundary.min() < 0 or boundary.max() >= vertices.shape[0]):
            raise ValueError(f"boundary must index vertices 0..{vertices.shape[0] - 1}")
        for name, array in (
            ("vertices", vertices),
            ("triangles", triangles),
            ("boundary", boundary),
            ("boundary_parameters", parameters),
        ):
            array.setflags(write=False)
            object.__setattr__(self, name, array)

    def __repr__(self) -> str:
        return (
            f"Mesh(vertices={self.vertices.shape[0]}, triangles={self.triangles.shape[0]}, "
            f"boundary={self.boundary.shape[0]})"
        )

    @property
    def interior(self) -> np.ndarray:
        """int64 ndarray of shape (V - B,): indices of the vertices not on the curve."""
        mask = np.ones(self.vertices.shape[0], dtype=bool)
        mask[self.boundary] = False
        return np.flatnonzero(mask)

    def edges(self) -> np.ndarray:
        """Unique undirected edges, int64 ndarray of shape (E, 2) with ``edges[:, 0] < edges[:, 1]``."""
        return unique_edges(self.triangles)

    def signed_areas(self, vertices=None) -> np.ndarray:
        """Signed triangle areas, ndarray of shape (T,), positive when counter-clockwise (y up).

        Parameters
        ----------
        vertices : array_like of shape (V, 2), optional
            Other positions of the same vertices (e.g. the deformed mesh);
            defaults to `self.vertices`.
        """
        if vertices is None:
            vertices = self.vertices
        else:
            vertices = as_points(vertices, "vertices")
            if vertices.shape[0] != self.vertices.shape[0]:
                raise ValueError(
                    f"vertices must have {self.vertices.shape[0]} rows like the mesh, got {vertices.shape[0]}"
                )
        return triangle_signed_areas(vertices, self.triangles)

    def angles(self) -> np.ndarray:
        """Interior angles in radians, ndarray of shape (T, 3); column k is the angle at vertex k."""
        corners = self.vertices[self.triangles]  # (T, 3, 2)
        result = np.empty(self.triangles.shape)
        for k in range(3):
            u = corners[:, (k + 1) % 3] - corners[:, k]
            v = corners[:, (k + 2) % 3] - corners[:, k]
            result[:, k] = np.arctan2(np.abs(cross(u, v)), np.einsum("td,td->t", u, v))
        return result


#: A deformed triangle counts as folded (turned over or collapsed) when its signed area is at most
#: this share of its own, at the deformation's scale (`folded_limits`; `folded_triangles`, and the
#: fold-free maps and repairs of `core.injectivity`).
FOLDED_AREA_SHARE = 1e-9


def folded_limits(areas: np.ndarray, deformed_areas: np.ndarray, tolerance: float = FOLDED_AREA_SHARE):
    """The signed area (T,) at or below which each deformed triangle counts as folded.

    `tolerance` times the triangle's own signed area (T,), times the ratio of the deformed triangles'
    total signed area (T,) to the mesh's (the area of the boundary's image over the domain's), so
    that a fold is told apart from a uniform shrink at every scale: a map shrunk to 1e-5 of the
    cage's size scales every area by 1e-10, which is no fold.
    """
    scale = abs(float(np.sum(deformed_areas))) / float(np.sum(areas))
    return tolerance * scale * areas


def folded_triangles(mesh: Mesh, deformed_vertices, tolerance: float = FOLDED_AREA_SHARE) -> np.ndarray:
    """Triangles that the deformation folds over or collapses.

    Parameters
    ----------
    mesh : Mesh
        The undeformed mesh (all triangles counter-clockwise).
    deformed_vertices : array_like of shape (V, 2)
        The deformed vertex positions, in the same frame as ``mesh.vertices``.
    tolerance : float
        A triangle counts as collapsed when its deformed signed area is at most
        ``tolerance`` times its undeformed area, at the deformation's scale (`folded_limits`).

    Returns
    -------
    ndarray of shape (T,), bool
        True where the signed area changed sign or became (almost) zero.
    """
    if not isinstance(mesh, Mesh):
        raise ValueError(f"mesh must be a core.Mesh, got {type(mesh).__name__}")
    tolerance = positive_float(tolerance, "tolerance")
    deformed = mesh.signed_areas(deformed_vertices)
    return deformed <= folded_limits(mesh.signed_areas(), deformed, tolerance)


def require_mesh_of(curve: ClosedBSpline, mesh: Mesh) -> None:
    """Raise `ValueError` unless `mesh` is a Mesh whose boundary vertices are ``curve(boundary_parameters)``.

    The tolerance, 1e-9 of the diameter, accepts meshes saved and reloaded as
    text but not a mesh of another cage.
    """
    if not isinstance(curve, ClosedBSpline):
        raise ValueError(f"curve must be a core.ClosedBSpline, got {type(curve).__name__}")
    if not isinstance(mesh, Mesh):
        raise ValueError(f"mesh must be a core.Mesh, got {type(mesh).__name__}")
    if mesh.boundary.size == 0:
        raise ValueError("mesh has no boundary vertices; make it with core.triangulate(curve)")
    gap = np.abs(mesh.vertices[mesh.boundary] - curve(mesh.boundary_parameters)).max()
    if not gap <= 1e-9 * curve.diameter:
        raise ValueError(
            f"mesh was not made for this curve: its boundary vertices are up to {gap:.3g} away "
            "from curve(boundary_parameters); make it with core.triangulate(curve)"
        )


def cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def triangle_signed_areas(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    a, b, c = vertices[triangles[:, 0]], vertices[triangles[:, 1]], vertices[triangles[:, 2]]
    return 0.5 * cross(b - a, c - a)


def unique_edges(triangles: np.ndarray) -> np.ndarray:
    """Each undirected edge of the triangles once, (low, high), in lexicographic order.

    Parameters
    ----------
    triangles : ndarray of shape (T, 3), non-negative integers

    Returns
    -------
    ndarray of shape (E, 2), int64

    Edges are keyed as one integer, low * V + high, sorted, and the repeats dropped:
    for 800k triangles ``np.unique(axis=0)`` on the pairs took 7.4 s (numpy 2.4),
    one sort of the keys takes 0.1 s.
    """
    triangles = np.asarray(triangles, dtype=np.int64)
    pairs = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    low, high = pairs.min(axis=1), pairs.max(axis=1)
    stride = high.max() + 1
    keys = np.sort(low * stride + high)
    keys = keys[np.concatenate([[True], keys[1:] != keys[:-1]])]
    return np.stack([keys // stride, keys % stride], axis=1)
