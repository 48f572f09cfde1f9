"""The deformation of a basis: deformed points from coordinates and target control points.

Real coordinates G (M, n) map target control points P' (n, 2) to ``G @ P'``; the
complex Cauchy–Green coordinates (`core.boundary_integrals.cauchy_green`) act on the points as complex
numbers, f = C (P'_x + i P'_y).  `deform` is both, so that every caller draws either.
"""

from __future__ import annotations

import numpy as np


def deform(basis: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Deformed points, float ndarray of shape (M, 2), of coordinates (M, n) and target (n, 2)."""
    if np.iscomplexobj(basis):
        image = basis @ (target[:, 0] + 1j * target[:, 1])
        return np.stack([image.real, image.imag], axis=1)
    return basis @ target
