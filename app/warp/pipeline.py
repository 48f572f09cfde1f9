"""The warp of an image by a cage: the one pipeline of `warp`, `animate`, the viewer's export and `quality`.

A warp is two steps, as in the paper's Sec. 4.3:

1. `prepare`: mesh the cage's interior and compute the basis functions G (V, n) at
   the mesh vertices, once per cage and kernel (the slow part, cached on disk by
   `core.mesh_basis_functions`);
2. `Deformation.positions` and `render`: the deformed vertices f(v) = sum_i G_i(v) P_i
   for a target (V, n) @ (n, 2), then the source image drawn on the deformed mesh.

Every command that writes warped pixels goes through `render`, so `warp`, each frame
of `animate` and the viewer's export of the same target are the same pixels; `quality`
measures `Deformation.positions` of the same `prepare`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import core
from app.io.images import DEFAULT_QUALITY, ImageMetadata
from app.render.viewport import View
from core import deform


@dataclass(frozen=True)
class WarpSettings:
    """How to deform: everything `prepare` needs besides the cage.

    Attributes
    ----------
    kernel : str
        A kernel of `core.mesh_basis_functions` (default: the package default, ``"poisson"``).
    params : dict
        Its keyword parameters (``power``, ``parameterization``, ``samples_per_segment``...).
    max_edge : float, optional
        Longest mesh edge in image pixels; None for the automatic size.
    cache : bool
        Read and write the on-disk basis cache.
    fold_free : bool
        Deform by `core.fold_free_deform` (a certified bijection onto the target; ``poisson`` only)
        instead of G P'.
    """

    kernel: str = core.DEFAULT_KERNEL
    params: dict = field(default_factory=dict)
    max_edge: float | None = None
    cache: bool = True
    fold_free: bool = False


#: Outputs of more pixels than this (one 4096 x 4096 tile) are written strip by strip when PNG;
#: smaller ones are encoded whole, byte for byte as before.
STREAMED_PIXELS = 4096 * 4096


@dataclass(frozen=True)
class OutputFile:
    """Where and how a warp is written.

    Attributes
    ----------
    path : Path
        The file; its extension chooses the format (`app.io.images.output_format`).
    metadata : app.io.images.ImageMetadata, optional
        The input's ICC profile and EXIF block.
    quality : int
        JPEG and WebP quality.
    background : tuple of float, optional
        Straight RGBA in [0, 1] under the warp (``--background``); transparent if None.
    """

    path: Path
    metadata: ImageMetadata | None = None
    quality: int = DEFAULT_QUALITY
    background: tuple[float, float, float, float] | None = None


@dataclass(frozen=True)
class Deformation:
    """A cage's precomputed deformation.

    Attributes
    ----------
    mesh : core.Mesh
        The triangulated interior, V vertices in image pixels.
    basis : ndarray of shape (V, n)
        G at the mesh vertices; complex for the Cauchy-Green kernel.
    kernel : str
        The kernel that computed `basis`.
    curve : core.ClosedBSpline, optional
        The cage (needed by `fold_free` and `certificate`).
    fold_free : bool
        `positions` are those of `core.fold_free_deform`, not G P'.
    """

    mesh: core.Mesh
    basis: np.ndarray
    kernel: str
    curve: core.ClosedBSpline | None = None
    fold_free: bool = False
    _last: dict = field(default_factory=dict, compare=False, repr=False)

    def positions(self, target: np.ndarray) -> np.ndarray:
        """Deformed vertices (V, 2) for the target control points (n, 2): `core.deform`, or the
        certified fold-free map (ValueError where the straight path of cages crosses itself)."""
        if not self.fold_free:
            return deform(self.basis, target)
        return self.fold_free_map(target)[0]

    def certificate(self, target: np.ndarray) -> core.InjectivityCertificate | None:
        """What is proven about the map to `target` (`core.certify_injective`; when `fold_free`, of the
        mesh's fold-free map, or of the continuous map where that map is the plain one and proven);
        None for kernels whose maps are not harmonic."""
        if self.fold_free:
            certificate = self.fold_free_map(target)[1]
            if certificate.extra.get("path") != core.PLAIN_HARMONIC_MAP:
                return certificate
            # The plain map, proven on the mesh: its continuous certificate says more where it proves.
            continuous = core.certify_injective(self.curve, target)
            return continuous if continuous.injective else certificate
        if self.kernel != core.DEFAULT_KERNEL or self.curve is None:
            return None
        return core.certify_injective(self.curve, target)

    def fold_free_map(
        self, target: np.ndarray, progress: Callable[[float], None] | None = None
    ) -> tuple[np.ndarray, core.InjectivityCertificate]:
        """`core.fold_free_deform` of the mesh's vertices onto `target` (n, 2): positions (V, 2) and
        certificate, kept for the last target (`warp` asks for the positions, the report and the
        render); `progress` gets the share of the path proven."""
        key = np.asarray(target, dtype=np.float64).tobytes()
        if key not in self._last:
            self._last.clear()
            boundary = (self.mesh.boundary, self.mesh.boundary_parameters)
            self._last[key] = core.fold_free_deform(
                self.curve,
                target,
                self.mesh.vertices,
                boundary=boundary,
                triangles=self.mesh.triangles,
                progress=progress,
                basis=self.basis,
            )
        return self._last[key]


def prepare(
    curve: core.ClosedBSpline,
    settings: WarpSettings,
    mesh: core.Mesh | None = None,
    progress: Callable[[float], None] | None = None,
    compiling: Callable[[float], None] | None = None,
    meshing: Callable[[float], None] | None = None,
) -> Deformation:
    """Mesh the cage (unless `mesh` is given) and compute its basis functions.

    Parameters
    ----------
    curve : core.ClosedBSpline
        The cage, n control points.
    settings : WarpSettings
        Kernel, parameters, mesh size and caching.
    mesh : core.Mesh, optional
        A mesh of `curve` to use instead of ``core.triangulate(curve, settings.max_edge)``.
    progress, compiling : callable, optional
        Fractions of the basis computation and of a first-run compilation
        (`core.mesh_basis_functions`).
    meshing : callable, optional
        Fractions of the meshing (`core.triangulate`).

    Raises
    ------
    ValueError
        From `core.triangulate` and `core.mesh_basis_functions`, for a cage or settings they refuse.
    """
    if settings.fold_free and settings.kernel != core.DEFAULT_KERNEL:
        raise ValueError(
            f"fold-free warps are harmonic: they need the {core.DEFAULT_KERNEL} kernel, "
            f"got {settings.kernel!r}"
        )
    if mesh is None:
        mesh = core.triangulate(curve, max_edge=settings.max_edge, progress=meshing)
    if progress is not None:
        progress(0.0)  # the basis phase begins (a superseded viewer request stops here)
    basis = core.mesh_basis_functions(
        curve,
        mesh,
        kernel=settings.kernel,
        progress=progress,
        compiling=compiling,
        cache=settings.cache,
        **settings.params,
    )
    return Deformation(mesh, basis, settings.kernel, curve, settings.fold_free)


def render(
    renderer,
    deformation: Deformation,
    target: np.ndarray,
    size: tuple[int, int],
    view: View,
    outside: str,
    background: tuple[float, float, float, float] | None = None,
) -> np.ndarray:
    """The image on `renderer` drawn on the mesh deformed to `target`.

    Parameters
    ----------
    renderer : app.render.renderer.WarpRenderer
        Holds the source image and `deformation.mesh` (`set_image`, `set_mesh`).
    deformation : Deformation
    target : ndarray of shape (n, 2)
        Target control points, image pixels.
    size : tuple of int
        (width, height) of the output.
    view : View
        Image pixels to output pixels.
    outside : str
        ``"original"`` draws the source image behind the warp, ``"transparent"`` leaves it clear.
    background : tuple of float, optional
        Straight RGBA in [0, 1] under everything (``--background``); transparent if None.

    Returns
    -------
    ndarray of shape (height, width, 4), uint8, or uint16 for a 16-bit source image
        RGBA with straight alpha.
    """
    renderer.set_positions(deformation.positions(target))
    clear = (0.0, 0.0, 0.0, 0.0) if background is None else background
    return renderer.render(size, view, backdrop=outside == "original", background=clear)


def render_to_file(
    renderer,
    deformation: Deformation,
    target: np.ndarray,
    frame: tuple[tuple[int, int], View],
    outside: str,
    output: OutputFile,
    last: bool = False,
) -> Callable[[], None] | None:
    """`render` written to `output.path` in its format: a PNG larger than one strip is drawn and
    compressed strip by strip (`WarpRenderer.render_strips`), so that the output is never whole in
    memory and compressing overlaps drawing; other outputs are rendered whole, then encoded.

    Parameters
    ----------
    renderer, deformation, target, outside
        As in `render`.
    frame : tuple
        (width, height) of the output and the `View` of image pixels to output pixels.
    output : OutputFile
        Where and how to write.
    last : bool
        The image is drawn no more (``warp``): a whole output is not encoded here but returned as
        a function that writes it, to call once the GL context is released, so that the
        encoder's memory does not come on top of the driver's textures.

    Returns
    -------
    callable or None
        With `last`, what writes a whole output; None once the file is written.

    Raises
    ------
    app.io.files.InputError
        The file cannot be written, or transparent pixels for a JPEG (nothing is written).
    """
    from app.io.files import write_image, write_png_strips
    from app.io.images import output_format
    from app.io.images.tiles import crosses, drawn_edges
    from app.render.renderer import STRIP_ROWS

    size, view = frame
    background = (0.0, 0.0, 0.0, 0.0) if output.background is None else output.background
    if output_format(output.path) == "PNG" and size[1] > STRIP_ROWS and size[0] * size[1] > STREAMED_PIXELS:
        positions = deformation.positions(target)
        renderer.set_positions(positions)
        edges = None
        if not core.folded_triangles(deformation.mesh, positions).any():  # folds: edges everywhere
            edges = drawn_edges(deformation.mesh, positions, view, renderer.image_size, outside == "original")
        strips = renderer.render_strips(
            size,
            view,
            backdrop=outside == "original",
            background=background,
            antialiased=None if edges is None else lambda box: crosses(edges, box),
        )
        write_png_strips(output.path, size, renderer.pixel_type, strips, output.metadata)
        return None
    pixels = render(renderer, deformation, target, size, view, outside, output.background)
    if last:  # encoded once the caller has let go of the GL context, and the textures with it
        return lambda: write_image(output.path, pixels, output.metadata, output.quality, consume=True)
    write_image(output.path, pixels, output.metadata, output.quality)
    return None


__all__ = ["Deformation", "OutputFile", "WarpSettings", "prepare", "render", "render_to_file"]
