"""Cauchy integrals over panels, with a near-field rule that holds down to the boundary.

Both boundary-integral kernels are Cauchy integrals over the source curve Γ,

    C[φ](z) = (1 / 2πi) ∮_Γ φ(τ) / (τ - z) dτ,

of a density φ given at the panel nodes of `core.panels`: the transfinite harmonic
coordinates are G_i = Re C[μ_i] for the double-layer densities μ_i (`core.poisson`),
the Cauchy–Green coordinates are C[N_i] (`core.cauchy_green`).  A row of *weights*
W(z) (one complex number a node) gives C[φ](z) = W(z) · φ.

Far from a panel the weights are its Gauss–Legendre rule, w_k τ'_k / (2πi (τ_k - z)).
Near it (closer than `SAFE` times its arc length), the panel is bisected in t until
every piece is at least `SAFE` times its own length away from z; each piece's
Gauss–Legendre rule is applied to the Lagrange interpolant of φ on the panel's nodes,
and the result is mapped back onto the nodes (adaptive panel upsampling in the sense
of Klöckner, Barnett, Greengard and O'Neil's QBX error analysis, here with the exact
curve).  Its error is that of interpolating φ on the panel, not that of the rule, so
it holds at any distance from Γ; targets that `MAX_DEPTH` bisections do not separate
from the curve are reported as on it, and left to the caller.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from core.bspline import ClosedBSpline
from core.panels import _NODES, _WEIGHTS, ORDER, Panels, interpolation_matrix

#: Points per block of the far-field products (bounds the memory of a block's weights).
BLOCK = 512

#: A piece's Gauss–Legendre rule is used when the target is at least this many piece lengths
#: away from it (error below ~1e-13 of the piece's contribution for the values, 1e-11 for
#: the derivative).
SAFE = 0.5
#: Pairs closer than this fraction of the diameter get their weights directly: the far
#: field's expanded products lose ~1e-16 / distance^2 (relative, distance in diameters).
DIRECT = 1e-3
#: Bisections at most; a target that needs more, or pieces shorter than `ON_CURVE`
#: diameters, or that comes that close to a node, is taken to be on the curve.
MAX_DEPTH = 60
ON_CURVE = 1e-10


def near_pairs(panels: Panels, targets: np.ndarray, diameter: float) -> tuple[np.ndarray, np.ndarray]:
    """(target index, panel index) pairs computed one by one, two int64 arrays sorted by target.

    A pair needs the adaptive rule when the target is closer to one of the panel's
    nodes than `SAFE` times the panel's arc length (otherwise the panel's own
    Gauss–Legendre rule holds), and it needs its weights computed directly, not by
    the far field's expanded products, within `DIRECT` diameters.
    """
    close_range = np.maximum(SAFE * panels.lengths, DIRECT * diameter)
    reach = panels.radii + close_range
    tree = cKDTree(np.stack([targets.real, targets.imag], axis=1))
    found = tree.query_ball_point(np.stack([panels.centres.real, panels.centres.imag], axis=1), reach)
    sizes = np.fromiter((len(f) for f in found), dtype=np.int64, count=len(found))
    if sizes.sum() == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    target = np.concatenate([np.asarray(f, dtype=np.int64) for f in found if len(f)])
    panel = np.repeat(np.arange(panels.count), sizes)
    nodes = panels.z.reshape(-1, ORDER)
    gap = np.abs(nodes[panel] - targets[target, None]).min(axis=1)
    close = gap < close_range[panel]
    target, panel = target[close], panel[close]
    order = np.lexsort((panel, target))
    return target[order], panel[order]


def adaptive_weights(
    curve: ClosedBSpline, panels: Panels, targets: np.ndarray, panel: np.ndarray, power: int = 1
) -> tuple[np.ndarray, np.ndarray]:
    """Weights of ∫_panel φ(τ) / (τ - z)^power dτ on the panel's nodes, for target/panel pairs.

    Parameters
    ----------
    targets : complex ndarray of shape (K,)
        z of each pair.
    panel : int ndarray of shape (K,)
        The panel of each pair.
    power : int
        1 for the Cauchy integral, 2 for its z-derivative.

    Returns
    -------
    complex ndarray of shape (K, ORDER)
        ``weights @ φ[panel nodes]`` is the integral of φ's interpolant.
    bool ndarray of shape (K,)
        The target is on the curve: it needs pieces shorter than `ON_CURVE`
        diameters, comes that close to a node, or needs `MAX_DEPTH` bisections.
    """
    touch = ON_CURVE * curve.diameter
    pieces = curve.piecewise_polynomial().coefficients
    weights = np.zeros((targets.shape[0], ORDER), dtype=np.complex128)
    touching = np.zeros(targets.shape[0], dtype=bool)
    pair = np.arange(targets.shape[0])
    low = np.full(pair.shape, -1.0)
    high = np.full(pair.shape, 1.0)
    bounds = panels.bounds
    span = np.floor(bounds[:, 0] + 1e-12).astype(np.int64)
    for depth in range(MAX_DEPTH + 1):
        if pair.size == 0:
            break
        p = panel[pair]
        half = 0.5 * (high - low)
        u = 0.5 * (high + low)[:, None] + half[:, None] * _NODES  # (K, q) in the panel's [-1, 1]
        panel_half = 0.5 * (bounds[p, 1] - bounds[p, 0])
        t_local = (0.5 * (bounds[p, 0] + bounds[p, 1]) - span[p])[:, None] + panel_half[:, None] * u
        c = pieces[span[p] % curve.n]  # (K, 3, 2)
        x = c[:, None, 0, 0] + t_local * (c[:, None, 1, 0] + t_local * c[:, None, 2, 0])
        y = c[:, None, 0, 1] + t_local * (c[:, None, 1, 1] + t_local * c[:, None, 2, 1])
        dx = c[:, None, 1, 0] + 2.0 * t_local * c[:, None, 2, 0]
        dy = c[:, None, 1, 1] + 2.0 * t_local * c[:, None, 2, 1]
        tau = x + 1j * y
        dtau = dx + 1j * dy
        scale = (half * panel_half)[:, None] * _WEIGHTS
        length = (scale * np.abs(dtau)).sum(axis=1)
        gap = np.abs(tau - targets[pair, None]).min(axis=1)
        far = gap >= SAFE * length
        on = ((gap < touch) | (length < touch) | (depth == MAX_DEPTH)) & ~far
        touching[pair[on]] = True
        if far.any():
            rule = scale[far] * dtau[far] / (tau[far] - targets[pair[far], None]) ** power
            basis = _pieces_interpolation(low[far], high[far])
            np.add.at(weights, pair[far], np.einsum("kq,kqj->kj", rule, basis))
        split = ~far & ~on
        middle = 0.5 * (low[split] + high[split])
        pair = np.concatenate([pair[split], pair[split]])
        low, high = np.concatenate([low[split], middle]), np.concatenate([middle, high[split]])
    return weights, touching


def _pieces_interpolation(low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """`interpolation_matrix` at the Gauss nodes of the pieces [low, high] of [-1, 1], shape (K, q, q).

    Bisection makes few distinct pieces (dyadic intervals), so each is computed once.
    """
    pieces, inverse = np.unique(np.stack([low, high], axis=1), axis=0, return_inverse=True)
    u = 0.5 * (pieces[:, 1] + pieces[:, 0])[:, None] + 0.5 * (pieces[:, 1] - pieces[:, 0])[:, None] * _NODES
    return interpolation_matrix(u)[inverse.ravel()]


def layer_factors(curve: ClosedBSpline, panels: Panels) -> np.ndarray:
    """s w_k τ'_k / 2πi at the nodes, complex (P * ORDER,): node k's Cauchy weight is factor_k / (τ_k - z).

    s = +1 for a counter-clockwise curve, -1 otherwise, so that C[1] = 1 inside.
    """
    orientation = 1.0 if curve.area > 0 else -1.0
    return orientation * panels.weights * panels.dz / (2j * np.pi)


def cauchy_integrals(
    curve: ClosedBSpline, panels: Panels, density: np.ndarray, x: np.ndarray, *, imaginary: bool
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """C[φ](x) for the columns φ of `density` (P * ORDER, k) at points x (M, 2).

    Returns the real parts (M, k), the imaginary parts (M, k) if `imaginary` (else
    None) and the on-curve flags (M,).  The far field is two small products per
    block: Re(e / (τ - z)) = (Re(e conj τ) - Re(e conj z)) / |τ - z|^2, in
    coordinates centred on the nodes and scaled by the diameter, so that its
    cancellation costs at most ~1e-16 / (distance / diameter)^2 relative, and near
    pairs are replaced by `adaptive_weights`.
    """
    factors = layer_factors(curve, panels)
    z = x[:, 0] + 1j * x[:, 1]
    centre = panels.z.mean()
    scale = 1.0 / curve.diameter
    tau = (panels.z - centre) * scale
    e = factors * scale  # e / (τ_s - z_s) equals factors / (τ - z)
    real_rows = np.stack([(e * tau.conj()).real, -e.real, -e.imag])
    imaginary_rows = np.stack([(e * tau.conj()).imag, -e.imag, e.real])
    denominator_rows = np.stack([np.abs(tau) ** 2, -2.0 * tau.real, -2.0 * tau.imag, np.ones(tau.size)])
    target, panel = near_pairs(panels, z, curve.diameter)
    weights, touching = adaptive_weights(curve, panels, z[target], panel)
    orientation = 1.0 if curve.area > 0 else -1.0
    near = orientation * weights / (2j * np.pi)
    on_curve = np.zeros(z.size, dtype=bool)
    on_curve[target[touching]] = True
    real = np.empty((z.size, density.shape[1]))
    imag = np.empty_like(real) if imaginary else None
    starts = np.searchsorted(target, np.arange(0, z.size + BLOCK, BLOCK))
    for block, first in enumerate(range(0, z.size, BLOCK)):
        w = (z[first : first + BLOCK] - centre) * scale
        left = np.stack([np.ones(w.size), w.real, w.imag], axis=1)
        denominator = np.concatenate([left, (np.abs(w) ** 2)[:, None]], axis=1) @ denominator_rows
        pairs = slice(starts[block], starts[block + 1])
        rows = target[pairs, None] - first
        columns = panel[pairs, None] * ORDER + np.arange(ORDER)
        part = left @ real_rows
        part /= denominator
        part[rows, columns] = near[pairs].real
        real[first : first + BLOCK] = part @ density
        if imaginary:
            part = left @ imaginary_rows
            part /= denominator
            part[rows, columns] = near[pairs].imag
            imag[first : first + BLOCK] = part @ density
    return real, imag, on_curve


def cauchy_derivatives(
    curve: ClosedBSpline, panels: Panels, density: np.ndarray, x: np.ndarray
) -> np.ndarray:
    """d/dz C[φ](x), complex (M, k), for the columns φ of `density` (P * ORDER, k) at points x (M, 2)."""
    factors = layer_factors(curve, panels)
    z = x[:, 0] + 1j * x[:, 1]
    target, panel = near_pairs(panels, z, curve.diameter)
    weights, _ = adaptive_weights(curve, panels, z[target], panel, power=2)
    orientation = 1.0 if curve.area > 0 else -1.0
    near = orientation * weights / (2j * np.pi)
    out = np.empty((z.size, density.shape[1]), dtype=np.complex128)
    starts = np.searchsorted(target, np.arange(0, z.size + BLOCK, BLOCK))
    for block, first in enumerate(range(0, z.size, BLOCK)):
        part = factors / (panels.z[None, :] - z[first : first + BLOCK, None]) ** 2
        pairs = slice(starts[block], starts[block + 1])
        part[target[pairs, None] - first, panel[pairs, None] * ORDER + np.arange(ORDER)] = near[pairs]
        out[first : first + BLOCK] = part @ density
    return out
