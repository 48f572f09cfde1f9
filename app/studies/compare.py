"""``python -m app compare``: the kernels of `core` side by side on height data (the paper's Fig. 1).

For a cage with n control points and boundary values F_1..F_n, the interpolant of
each kernel is g = G F with G from `core.mesh_basis_functions` at the vertices of
one mesh of the domain (Sec. 4.3).  Every interpolant is compared with the
harmonic one (Sec. 4.2), the paper's reference, by its area-weighted RMS and its
maximum distance over the vertices.  The point kernels integrate over the boundary
in its natural B-spline parameter, in its arc length (``--parameterization
arc-length``, `core.curves.arc_length`) or both, side by side (the paper's Fig. 12).  The
figure shows each one from above in height bands of 0.1 (negative red, above 1
green, blue to yellow in between).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

import cv2
import numpy as np

from app.console import EXIT_OK, ProgressBar, note
from app.io.files import (
    InputError,
    cage_curve,
    check_writable,
    finite_number,
    kernel_names,
    read_cage,
    read_json,
    refuse_overwriting_inputs,
    reported_as_input,
    write_png,
)
from core import COMPILE_MESSAGE as COMPILING
from core import MESH_ONLY_KERNELS

#: Reference kernel of the comparison.
REFERENCE = "harmonic"

PANEL_SIZE = 360
LABEL_HEIGHT = 44
COLUMNS = 4
COLOUR_BAR_WIDTH = 110
FONT = cv2.FONT_HERSHEY_SIMPLEX


@dataclass
class Interpolant:
    """One kernel's interpolant at the mesh vertices."""

    label: str
    values: np.ndarray  # (V,)
    seconds: float
    rms: float = 0.0
    maximum: float = 0.0


def kernel_variants(
    kernels: list[str] | None = None, parameterization: str = "natural"
) -> list[tuple[str, str, dict]]:
    """(label, kernel, params) of every interpolant to compare, the reference first.

    ``power`` appears with each shift of Eq. 19 (.docs/architecture.md, "Numerical rules") so the
    figure shows how much the shift changes the interpolant.  The point kernels
    appear in the `parameterization` (``"natural"``, ``"arc-length"``, or
    ``"both"``: the natural one, then the arc-length one); ``harmonic`` and
    ``pgw`` do not depend on it and appear once.
    """
    names = kernels if kernels else kernel_names()
    variants = [(REFERENCE, REFERENCE, {})]
    for name in dict.fromkeys(names):
        if name == REFERENCE:
            continue
        if name == "power":
            variants += [
                (f"power 3, shift {shift}", "power", {"power": 3.0, "shift": shift})
                for shift in ("none", "integral", "mean")
            ]
        else:
            variants.append((name, name, {}))
    if parameterization == "natural":
        return variants
    natural = parameterization == "both"
    parameterized = []
    for label, kernel, params in variants:
        if kernel in MESH_ONLY_KERNELS:
            parameterized.append((label, kernel, params))
            continue
        if natural:
            parameterized.append((label, kernel, params))
        parameterized.append((f"{label}, arc length", kernel, {**params, "parameterization": "arc-length"}))
    return parameterized


def run_compare(args: argparse.Namespace) -> int:
    """The ``compare`` command: table on stdout, figure to ``args.output``; returns the exit code."""
    import core
    from app.render.renderer import create_headless_context
    from core import wave_heights

    check_writable(args.output, suffix=".png")
    refuse_overwriting_inputs(args.output, {"domain cage": args.cage, "data file": args.data})
    curve = cage_curve(read_cage(args.cage), str(args.cage))
    values = _read_values(args.data, curve.n) if args.data else wave_heights(curve.n)
    unknown = [name for name in args.kernel or [] if name not in kernel_names()]
    if unknown:
        raise InputError(f"unknown kernel(s) {', '.join(unknown)}; choose from {', '.join(kernel_names())}")
    max_edge = args.max_edge if args.max_edge is not None else curve.diameter / 60.0
    # The GL context comes first: without one there is no point in the long precompute.
    ctx = create_headless_context()
    try:
        with reported_as_input(f"{args.cage}: meshing"):
            mesh = core.triangulate(curve, max_edge=max_edge)
        note(f"mesh: {len(mesh.vertices)} vertices, {len(mesh.triangles)} triangles")
        interpolants = compare_kernels(
            curve, mesh, values, args.kernel, str(args.cage), args.parameterization
        )
        print(format_table(interpolants))
        write_png(args.output, figure(ctx, mesh, interpolants))
    finally:
        ctx.release()
    note(f"wrote {args.output}")
    return EXIT_OK


def compare_kernels(
    curve, mesh, values: np.ndarray, kernels: list[str] | None, source: str, parameterization: str = "natural"
) -> list[Interpolant]:
    """Interpolants g = G F of every kernel variant, with their distances to the harmonic one.

    Parameters
    ----------
    curve : core.ClosedBSpline
        The domain, n control points.
    mesh : core.Mesh
        A mesh of it.
    values : ndarray of shape (n,)
        F_1..F_n.
    kernels : list of str or None
        Kernels to compare (`kernel_variants`); all by default.
    source : str
        Where the cage came from, for messages.
    parameterization : str
        ``"natural"``, ``"arc-length"`` or ``"both"`` (`kernel_variants`).

    Returns
    -------
    list of Interpolant
        The harmonic reference first; kernels that reject the domain are skipped with a note.
    """
    import core

    interpolants = []
    for label, kernel, params in kernel_variants(kernels, parameterization):
        started = time.perf_counter()
        try:
            with ProgressBar(COMPILING, announce=True) as compiling, ProgressBar(label) as bar:
                basis = core.mesh_basis_functions(
                    curve, mesh, kernel=kernel, progress=bar, compiling=compiling, **params
                )
        except ValueError as error:
            if kernel == REFERENCE:
                raise InputError(f"{source}: the harmonic reference failed: {error}") from None
            note(f"note: {label} skipped: {error}")
            continue
        # The height interpolant; complex coordinates (cauchy-green) show its real part.
        interpolants.append(Interpolant(label, (basis @ values).real, time.perf_counter() - started))

    weights = vertex_areas(mesh.vertices, mesh.triangles)
    reference = interpolants[0].values
    for item in interpolants:
        difference = item.values - reference
        item.rms = float(np.sqrt(np.sum(weights * difference**2) / np.sum(weights)))
        item.maximum = float(np.abs(difference).max())
    return interpolants


def vertex_areas(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Lumped area of each vertex (a third of its triangles' areas), shape (V,): the RMS weights."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    area = 0.5 * np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
    weights = np.zeros(len(vertices))
    np.add.at(weights, triangles.ravel(), np.repeat(area / 3.0, 3))
    return weights


def format_table(interpolants: list[Interpolant]) -> str:
    """Plain-text table: label, RMS and maximum distance to the harmonic interpolant, time."""
    width = max(len(item.label) for item in interpolants)
    lines = [f"{'kernel':<{width}}  {'RMS':>9}  {'max':>9}  {'time':>7}"]
    lines += [
        f"{item.label:<{width}}  {item.rms:9.5f}  {item.maximum:9.5f}  {item.seconds:6.2f}s"
        for item in interpolants
    ]
    return "\n".join(lines)


def figure(ctx, mesh, interpolants: list[Interpolant]) -> np.ndarray:
    """One panel per interpolant and a colour bar, drawn with `ctx`.

    Returns
    -------
    ndarray of shape (H, W, 4), uint8
        Opaque RGBA on white.
    """
    from app.render.renderer import WarpRenderer
    from app.render.viewport import View

    columns = min(COLUMNS, len(interpolants))
    rows = -(-len(interpolants) // columns)
    # RGB while drawing: OpenCV's antialiased text would blend the alpha channel too.
    canvas = np.full(
        (rows * (PANEL_SIZE + LABEL_HEIGHT), columns * PANEL_SIZE + COLOUR_BAR_WIDTH, 3), 255, dtype=np.uint8
    )
    low, high = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    view = View.fit((*low, *high), (PANEL_SIZE, PANEL_SIZE), margin=12)
    with WarpRenderer(ctx) as renderer:
        renderer.set_mesh(mesh.vertices, mesh.triangles)
        for index, item in enumerate(interpolants):
            renderer.set_field(item.values)
            panel = renderer.render((PANEL_SIZE, PANEL_SIZE), view, background=(1, 1, 1, 1), content="field")
            top = (index // columns) * (PANEL_SIZE + LABEL_HEIGHT)
            left = (index % columns) * PANEL_SIZE
            canvas[top + LABEL_HEIGHT : top + LABEL_HEIGHT + PANEL_SIZE, left : left + PANEL_SIZE] = panel[
                ..., :3
            ]
            _text(canvas, item.label, (left + 10, top + 20), 0.55)
            detail = "reference" if index == 0 else f"RMS {item.rms:.4f}  max {item.maximum:.4f}"
            _text(canvas, detail, (left + 10, top + 38), 0.42)
    _colour_bar(canvas, left=columns * PANEL_SIZE + 16, top=LABEL_HEIGHT + 12, height=PANEL_SIZE - 24)
    return np.dstack([canvas, np.full(canvas.shape[:2], 255, dtype=np.uint8)])


def _colour_bar(canvas: np.ndarray, left: int, top: int, height: int) -> None:
    """Bands from BAND_START (bottom) upwards, labelled at their edges, drawn into `canvas`."""
    from app.render.passes.fields import BAND_COLOURS, BAND_START, BAND_WIDTH

    count = len(BAND_COLOURS)
    edges = np.round(np.linspace(top + height, top, count + 1)).astype(int)
    for band, colour in enumerate(BAND_COLOURS):
        canvas[edges[band + 1] : edges[band], left : left + 24] = np.round(255 * colour).astype(np.uint8)
    cv2.rectangle(canvas, (left, top), (left + 24, top + height), (0, 0, 0), 1)
    for edge in range(1, count):
        value = BAND_START + edge * BAND_WIDTH
        label = f"{value:.1f}" if edge % 2 == 1 else ""
        cv2.line(canvas, (left + 24, edges[edge]), (left + 29, edges[edge]), (0, 0, 0), 1)
        if label:
            _text(canvas, label, (left + 33, edges[edge] + 5), 0.42)
    _text(canvas, "< 0", (left + 33, (edges[0] + edges[1]) // 2 + 5), 0.42)
    _text(canvas, "> 1", (left + 33, (edges[-2] + edges[-1]) // 2 + 5), 0.42)


def _text(canvas: np.ndarray, text: str, origin: tuple[int, int], size: float) -> None:
    cv2.putText(canvas, text, origin, FONT, size, (0, 0, 0), 1, cv2.LINE_AA)


def _read_values(path, count: int) -> np.ndarray:
    """Boundary values ``{"values": [F_1, ..., F_n]}`` from a JSON file, shape (n,)."""
    value = read_json(path)
    values = value.get("values") if isinstance(value, dict) else None
    if not isinstance(values, list) or not all(
        isinstance(v, (int, float)) and not isinstance(v, bool) for v in values
    ):
        raise InputError(f'{path}: expected {{"values": [F_1, ..., F_n]}} with n numbers')
    if len(values) != count:
        raise InputError(f"{path}: has {len(values)} values but the cage has {count} control points")
    numbers = [finite_number(v) for v in values]
    if None in numbers:
        index = numbers.index(None)
        raise InputError(f"{path}: values[{index}] must be a finite number, got {values[index]!r:.60}")
    return np.array(numbers, dtype=np.float64)
