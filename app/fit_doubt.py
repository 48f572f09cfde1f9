"""Signs that `app.fit` found the wrong subject in a photograph: colour and saliency.

Both are measured on GrabCut's small copy of the picture, where `app.fit` hands them
its masks.  `colour_separation` asks whether colour tells the subject from the
background around it; `salient_overflow` asks whether what stands out from the
picture's border runs on beyond the cage, so that the cage cuts through something
salient.  Arrays are (h, w) images, row 0 at the top.
"""

from __future__ import annotations

import cv2
import numpy as np

from app.fit_colours import MIN_SAMPLES, boundary_saliency, colour_model, log_likelihood


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


def salient_overflow(rgb: np.ndarray, cage: np.ndarray, allowed: np.ndarray) -> float:
    """How much of what stands out where the cage is lies outside it: area outside / area inside.

    The salient pixels are those whose `boundary_saliency` exceeds its Otsu threshold,
    within `allowed`.  Of their 8-connected regions, those that the cage's inside
    meets are kept; the result is their area outside the cage over their area inside
    it (0 when the cage holds them whole or meets none).  A cage around a subject
    holds its salient region; a cage that stops across one (a rocket's body without
    its nose, whose grey is like the sky's) leaves much of it outside.

    Parameters
    ----------
    rgb : ndarray of shape (h, w, 3), uint8
        The picture, RGB.
    cage : ndarray of shape (h, w), bool
        Inside the cage (the subject grown by the cage's margin).
    allowed : ndarray of shape (h, w), bool
        Where the subject may be (the rectangle, or the whole picture).
    """
    saliency = np.round(255 * boundary_saliency(rgb)).astype(np.uint8)
    otsu, _ = cv2.threshold(saliency, 0, 1, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    salient = ((saliency > otsu) & allowed).astype(np.uint8)
    _, labels = cv2.connectedComponents(salient, connectivity=8)
    met = np.unique(labels[cage & (salient > 0)])
    regions = np.isin(labels, met[met > 0])
    held = np.count_nonzero(regions & cage)
    return float(np.count_nonzero(regions & ~cage) / held) if held else 0.0
