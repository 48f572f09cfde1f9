"""The GL buffers of one triangle mesh, in a Z-order of its vertices, and the vertex arrays that
the passes draw it with.

A software rasteriser shades vertices in chunks of the index buffer, and on a dense mesh in
the mesher's order it re-shades most of them (llvmpipe, 800k triangles: the textured pass
1.4-2.6x and the fold pass 1.8-3.9x slower, depending on the load).  So the buffer rows
hold the vertices, and the on-screen index buffer the triangles, in the order of a
space-filling curve; a second index buffer keeps the caller's triangle order, so that where
folded triangles overlap an exported picture does not depend on the renderer.
"""

from __future__ import annotations

import moderngl
import numpy as np

from app.render.passes.fold_possible import FoldMargins
from core import unique_edges


def checked_mesh(vertices, triangles) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (V, 2) float64, triangles (T, 3)), or ValueError saying what is wrong."""
    vertices = np.asarray(vertices, dtype=np.float64)
    triangles = np.asarray(triangles)
    if vertices.ndim != 2 or vertices.shape[1] != 2 or vertices.shape[0] < 3:
        raise ValueError(f"vertices must have shape (V, 2) with V >= 3, got {vertices.shape}")
    if not np.isfinite(vertices).all():
        raise ValueError("vertices contain NaN or infinite values")
    if triangles.ndim != 2 or triangles.shape[1] != 3 or triangles.shape[0] < 1:
        raise ValueError(f"triangles must have shape (T, 3) with T >= 1, got {triangles.shape}")
    if (
        not np.issubdtype(triangles.dtype, np.integer)
        or triangles.min() < 0
        or triangles.max() >= len(vertices)
    ):
        raise ValueError(f"triangles must be integer indices into the {len(vertices)} vertices")
    return vertices, triangles


class MeshBuffers:
    """Buffers and vertex arrays of one mesh, positions undeformed, the field and highlight empty.

    Parameters
    ----------
    ctx : moderngl.Context
    vertices : ndarray of shape (V, 2)
        Undeformed vertices in image pixels, as `checked_mesh` returns them.
    triangles : ndarray of shape (T, 3)
        Vertex indices, as `checked_mesh` returns them.
    image_size : tuple of int
        (W, H): texture coordinates are vertices / (W, H).
    programs : dict
        ``programs[kind] = (program, attribute)``: a vertex array of each kind draws the
        positions and ``"in_uv"`` or ``"in_value"`` through the program.
    outline_program : moderngl.Program
        Draws the highlighted triangles and the edges from the positions alone.

    Attributes
    ----------
    vertices : ndarray of shape (V, 2)
        Undeformed, in the caller's order.
    order : ndarray of shape (V,)
        The caller's vertex held by each buffer row.
    triangle_indices : ndarray of shape (T, 3), uint32
        The caller's triangles, in buffer rows.
    positions, uv, values, highlighted : moderngl.Buffer
        Deformed vertices (V, 2) and texture coordinates (V, 2) float32, the field (V,)
        float32, the highlighted triangles (K, 3) uint32.
    vaos : dict
        ``vaos[order][kind]``: order "screen" (Z-ordered triangles) or "caller", kind one
        of `programs`.
    highlight_vao : moderngl.VertexArray
        The highlighted triangles, the first `highlight_count` of them.
    highlight_count : int
        How many triangles `write_highlighted` chose.
    has_field : bool
        Whether `write_values` has written the field.
    """

    def __init__(
        self,
        ctx: moderngl.Context,
        vertices: np.ndarray,
        triangles: np.ndarray,
        image_size: tuple[int, int],
        programs: dict[str, tuple[moderngl.Program, str]],
        outline_program: moderngl.Program,
    ):
        count = vertices.shape[0]
        order = np.argsort(_morton_codes(vertices), kind="stable")
        renumber = np.empty(count, dtype=np.int64)
        renumber[order] = np.arange(count)
        indices = renumber[triangles].astype("u4")
        screen = np.argsort(_morton_codes(vertices[triangles].mean(axis=1)), kind="stable")
        self.vertices, self.order, self.triangle_indices = vertices, order, indices
        self.highlight_count = 0
        self.has_field = False
        self._outline_program = outline_program
        #: What is derived from the mesh on first use: "fold_margins" (`FoldMargins`), "boundary",
        #: "chosen_first" (`chosen_first`'s index buffer and vertex array).
        self._derived: dict = {}
        self._edge_vao: moderngl.VertexArray | None = None
        self.positions = ctx.buffer(vertices[order].astype("f4").tobytes(), dynamic=True)
        self.uv = ctx.buffer(self._uv(image_size).tobytes())
        self.values = ctx.buffer(reserve=4 * count, dynamic=True)
        self.highlighted = ctx.buffer(reserve=indices.nbytes, dynamic=True)
        self._objects: list = [self.positions, self.uv, self.values, self.highlighted]
        self.vaos: dict = {}
        for name, triangle_order in (("screen", screen), ("caller", None)):
            ordered = indices if triangle_order is None else indices[triangle_order]
            index_buffer = ctx.buffer(np.ascontiguousarray(ordered).tobytes())
            self.vaos[name] = vaos = {}
            for kind, (program, attribute) in programs.items():
                second = (self.uv, "2f", "in_uv") if attribute == "in_uv" else (self.values, "1f", "in_value")
                vaos[kind] = ctx.vertex_array(
                    program, [(self.positions, "2f", "in_position"), second], index_buffer=index_buffer
                )
            self._objects += [*vaos.values(), index_buffer]
        position = [(self.positions, "2f", "in_position")]
        self.highlight_vao = ctx.vertex_array(outline_program, position, index_buffer=self.highlighted)
        self._objects.append(self.highlight_vao)

    def write_positions(self, positions: np.ndarray) -> None:
        """Write deformed positions (V, 2), image pixels, in the caller's order."""
        positions = np.asarray(positions)
        if positions.shape != self.vertices.shape:
            raise ValueError(f"positions must have shape {self.vertices.shape}, got {positions.shape}")
        self.positions.write(np.asarray(positions, dtype="f4")[self.order].tobytes())

    def write_ordered_positions(self, positions: np.ndarray) -> None:
        """Write float32 positions (V, 2), already in `order`, into the position buffer."""
        if positions.shape != self.vertices.shape or positions.dtype != np.float32:
            raise ValueError(f"positions must be float32 of shape {self.vertices.shape}")
        self.positions.write(np.ascontiguousarray(positions))

    def write_uv(self, image_size: tuple[int, int]) -> None:
        """Texture coordinates for an image of (W, H) pixels."""
        self.uv.write(self._uv(image_size).tobytes())

    def write_values(self, values: np.ndarray) -> None:
        """Write the per-vertex field (V,), in the caller's order."""
        values = np.asarray(values)
        if values.shape != (self.vertices.shape[0],):
            raise ValueError(f"values must have shape ({self.vertices.shape[0]},), got {values.shape}")
        self.values.write(np.asarray(values, dtype="f4")[self.order].tobytes())
        self.has_field = True

    def write_highlighted(self, triangles: np.ndarray) -> None:
        """Choose the highlighted triangles: indices (K,) into the caller's triangles, or a bool mask (T,)."""
        triangles = np.asarray(triangles)
        count = len(self.triangle_indices)
        if triangles.dtype == bool:
            if triangles.shape != (count,):
                raise ValueError(f"a triangle mask must have shape ({count},), got {triangles.shape}")
            triangles = np.flatnonzero(triangles)
        elif triangles.size == 0:
            triangles = np.zeros(0, dtype=np.int64)
        elif (
            not np.issubdtype(triangles.dtype, np.integer) or triangles.min() < 0 or triangles.max() >= count
        ):
            raise ValueError(f"triangles must be a mask or indices in 0..{count - 1}")
        selected = self.triangle_indices[triangles].reshape(-1, 3)
        if len(selected):
            self.highlighted.write(selected.tobytes())
        self.highlight_count = len(selected)

    def may_fold(self, positions: np.ndarray) -> bool:
        """`FoldMargins.may_fold` of this mesh for float32 positions (V, 2) in `order`."""
        if "fold_margins" not in self._derived:
            self._derived["fold_margins"] = FoldMargins(self.vertices[self.order], self.triangle_indices)
        return self._derived["fold_margins"].may_fold(positions)

    @property
    def boundary_edges(self) -> np.ndarray:
        """ndarray of shape (B, 2): the edges of one triangle only, as rows of the position buffer."""
        if "boundary" not in self._derived:
            edges = np.sort(self.triangle_indices[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
            unique, counts = np.unique(edges, axis=0, return_counts=True)
            self._derived["boundary"] = unique[counts == 1]
        return self._derived["boundary"]

    def chosen_first(self, chosen: np.ndarray, kept: np.ndarray) -> tuple[moderngl.VertexArray, int, int]:
        """The image pass's vertex array over the caller's triangles of `kept` (bool (T,)), in
        their order but those of `chosen` (bool (T,)) first, how many those are and how many in
        all (its buffer rewritten at each call).  Only where no triangles overlap (no folds) is it
        drawn as the caller's order is."""
        if "chosen_first" not in self._derived:
            ctx = self.positions.ctx
            program = self.vaos["caller"]["image"].program
            indices = ctx.buffer(reserve=self.triangle_indices.nbytes, dynamic=True)
            vao = ctx.vertex_array(
                program,
                [(self.positions, "2f", "in_position"), (self.uv, "2f", "in_uv")],
                index_buffer=indices,
            )
            self._objects += [vao, indices]
            self._derived["chosen_first"] = (indices, vao)
        indices, vao = self._derived["chosen_first"]
        first, rest = np.flatnonzero(chosen & kept), np.flatnonzero(kept & ~chosen)
        if len(first) + len(rest):
            indices.write(np.ascontiguousarray(self.triangle_indices[np.concatenate([first, rest])]))
        return vao, len(first), len(first) + len(rest)

    def edge_vao(self) -> moderngl.VertexArray:
        """The edges' vertex array, built on first use (0.5 s for a 400k-vertex mesh)."""
        if self._edge_vao is None:
            ctx = self._outline_program.ctx
            edges = ctx.buffer(unique_edges(self.triangle_indices).astype("u4").tobytes())
            self._edge_vao = ctx.vertex_array(
                self._outline_program,
                [(self.positions, "2f", "in_position")],
                index_buffer=edges,
                mode=moderngl.LINES,
            )
            self._objects += [self._edge_vao, edges]
        return self._edge_vao

    def release(self) -> None:
        for item in self._objects:
            item.release()
        self._objects = []

    def _uv(self, image_size: tuple[int, int]) -> np.ndarray:
        return (self.vertices[self.order] / np.array(image_size, dtype=np.float64)).astype("f4")


def _morton_codes(points: np.ndarray) -> np.ndarray:
    """Position of each point along a Z-order curve on a 1024 x 1024 grid over their bounding box.

    Parameters
    ----------
    points : ndarray of shape (K, 2)

    Returns
    -------
    ndarray of shape (K,), uint32
        Interleaved bits of the cell column (even bits) and row (odd bits).
    """
    low = points.min(axis=0)
    extent = np.maximum(points.max(axis=0) - low, 1e-300)
    cells = np.minimum((points - low) / extent * 1024, 1023).astype(np.uint32)
    spread = []
    for bits in cells.T:  # 10 bits apart into the even positions of 20
        bits = (bits | (bits << 8)) & 0x00FF00FF
        bits = (bits | (bits << 4)) & 0x0F0F0F0F
        bits = (bits | (bits << 2)) & 0x33333333
        bits = (bits | (bits << 1)) & 0x55555555
        spread.append(bits)
    return spread[0] | (spread[1] << 1)
