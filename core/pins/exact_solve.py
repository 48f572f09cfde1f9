"""The pins' map without a distortion bound, exactly: `exact_solution`, and `best_similarity`.

Lexicographic least squares in two stages (dense linear algebra on 2n + 4 unknowns):

1. the pins' images closest to their targets that the cage can reach: the least-squares solution of
   pins(x) = targets over the x that satisfy the hard rows (fixed control points, and a = 1, b = 0
   for a single pin), singular values below `RCOND` of the largest treated as zero, so that pins
   the cage cannot tell apart do not blow the cage up;
2. among the x that put the pins there, the one of least departure from a similarity (the mean
   squared distance of the target control points from S(source) + t, minimised over S and t too).

When the cage has the freedom (at most n well-separated pins and no fixed point in the way) stage 1
reaches every target, so the pins land exactly.  One pin: a = 1, b = 0 leaves the translation;
two pins: the similarity that places both has zero departure, so it is the answer.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import null_space

#: Relative singular values below this are treated as zero (pins the cage cannot follow apart).
RCOND = 1e-9


def exact_solution(
    pin_rows: np.ndarray, targets: np.ndarray, hard_rows: np.ndarray, hard_values: np.ndarray,
    departure: np.ndarray,
) -> np.ndarray:  # fmt: skip
    """The solution x (2n + 4,) of the two stages.

    Parameters
    ----------
    pin_rows : ndarray of shape (2m, 2n + 4)
        The pins' x images then y images as rows acting on x.
    targets : ndarray of shape (2m,)
        Their targets, x then y.
    hard_rows, hard_values : ndarray of shape (h, 2n + 4) and (h,)
        Rows that hold exactly.
    departure : ndarray of shape (2n, 2n + 4)
        `core.pins.linear_rows.departure_rows`.
    """
    width = pin_rows.shape[1]
    start, free = _affine_set(hard_rows, hard_values, width)
    shift, *_ = np.linalg.lstsq(pin_rows @ free, targets - pin_rows @ start, rcond=RCOND)
    reached = pin_rows @ (start + free @ shift)
    rows = np.vstack([hard_rows, pin_rows])
    start, free = _affine_set(rows, np.concatenate([hard_values, reached]), width)
    if free.shape[1] == 0:
        return start
    step, *_ = np.linalg.lstsq(departure @ free, -departure @ start, rcond=None)
    return start + free @ step


def _affine_set(rows: np.ndarray, values: np.ndarray, width: int) -> tuple[np.ndarray, np.ndarray]:
    """A point (width,) of {x : rows x = values} (least squares where inconsistent) and a basis
    (width, d) of the directions that keep rows x."""
    if rows.shape[0] == 0:
        return np.zeros(width), np.eye(width)
    point, *_ = np.linalg.lstsq(rows, values, rcond=RCOND)
    return point, null_space(rows, rcond=RCOND)


def best_similarity(pins: np.ndarray, targets: np.ndarray) -> tuple[complex, complex]:
    """The similarity z ↦ A z + t (complex A, t) closest in least squares to taking pins (m, 2) to
    targets (m, 2): the translation for one pin, exact for two."""
    p = pins[:, 0] + 1j * pins[:, 1]
    q = targets[:, 0] + 1j * targets[:, 1]
    if p.size == 1:
        return 1.0 + 0j, complex(q[0] - p[0])
    system = np.stack([p, np.ones_like(p)], axis=1)
    (linear, translation), *_ = np.linalg.lstsq(system, q, rcond=None)
    return complex(linear), complex(translation)


__all__ = ["RCOND", "best_similarity", "exact_solution"]
