"""A sign that `app.fit.subject` found the wrong subject in a photograph: colour hardly tells it apart.

`colour_separation` is measured on GrabCut's small copy of the picture, where `app.fit.subject`
hands it the subject and the background around it.  Arrays are (h, w) images, row 0 at
the top.
"""

from __future__ import annotations

import numpy as np

from app.fit.colours import MIN_SAMPLES, colour_model, log_likelihood


def colour_separation(bgr: np.ndarray, inside: np.ndarray, ring: np.ndarray) -> float:
    """How well colour tells the subject from the background around it, in [0, 1] (0.5: not at all).

    GrabCut's Gaussian mixtures (`colour_model`) are learned from the subject's
    pixels and from those of the ring of background around it; the result is the
    mean of the share of subject pixels more likely under the subject's model and
    the share of ring pixels more likely under the background's.  0.5 when either
    has fewer than `MIN_SAMPLES` pixels.

    Parameters
    ----------
    bgr : ndarray of shape (h, w, 3), uint8
        The picture, BGR.
    inside, ring : ndarray of shape (h, w), bool
        The subject, and the background around it.
    """
    if inside.sum() < MIN_SAMPLES or ring.sum() < MIN_SAMPLES:
        return 0.5
    subject_model, background_model = (
        colour_model(bgr[inside], bgr[ring]),
        colour_model(bgr[ring], bgr[inside]),
    )
    closer = log_likelihood(subject_model, bgr) > log_likelihood(background_model, bgr)
    return float(0.5 * (closer[inside].mean() + (~closer[ring]).mean()))
