"""Grow a photograph's subject into the parts of it that only the nearby background tells apart.

GrabCut (`app.fit.subject`) decides each pixel by colour models of the whole picture: a grey nose
of a rocket against a dark blue sky is left out when the lighter sky near the horizon and
the grey towers elsewhere share its colour.  Next to the nose, though, the sky is darker
and bluer than it, while the body's shades next to it are its own.  `locally_grown`
weighs each pixel just outside the subject against the colours of the subject near it
and of the background near it, and adds it when the subject's explain it better; it
repeats until nothing is added.  A part in colours that the subject near it lacks
(a dark logo on the nose) stops the growth there.  Arrays are (h, w) images, row 0 at
the top.
"""

from __future__ import annotations

import cv2
import numpy as np

#: Each round decides the pixels within this many pixels outside the subject (on the fine copy
#: of about `app.fit.subject.REFINE_PIXELS` pixels).
GROWTH_STEP = 2.0
#: The background near the subject is the ring from `GROWTH_STEP` to this many pixels outside it.
GROWTH_RING = 8.0
#: The subject's and the background's local colours are taken over a square of this half-width.
GROWTH_WINDOW = 8
#: The local variance of a colour (CIELAB units squared) is at least this: the noise of 8-bit samples.
GROWTH_VARIANCE = 4.0
#: At most this many rounds: the subject grows by at most `GROWTH_STEP` x `GROWTH_ROUNDS` pixels.
GROWTH_ROUNDS = 40


def within_bounds(shape: tuple[int, int], bounds: tuple[int, int, int, int]) -> np.ndarray:
    """bool ndarray of `shape` (h, w): True on the pixels of `bounds` (left, top, right, bottom; the
    right and bottom ones excluded)."""
    left, top, right, bottom = bounds
    inside = np.zeros(shape, bool)
    inside[top:bottom, left:right] = True
    return inside


def locally_grown(bgr: np.ndarray, subject: np.ndarray, bounds: tuple[int, int, int, int]) -> np.ndarray:
    """`subject` (h, w) uint8 grown where its nearby colours explain a pixel better than the background's.

    In each round the pixels within `GROWTH_STEP` outside the subject (and within `bounds`),
    and within `GROWTH_STEP` + 1 of a pixel that joined in the round before (the subject
    itself before the first), are weighed in CIELAB against the colours within a square of
    half-width `GROWTH_WINDOW` around them (`_local_cost`): the subject's pixels more than
    a pixel inside its outline, and the background's ring from `GROWTH_STEP` to
    `GROWTH_RING` outside it.  Those that the subject's colours explain better join it.
    The rounds stop when none joins, or after `GROWTH_ROUNDS`.

    Parameters
    ----------
    bgr : ndarray of shape (h, w, 3), uint8
        The picture, BGR.
    subject : ndarray of shape (h, w), uint8
        1 on the subject before it grows.
    bounds : (left, top, right, bottom)
        The pixels it may grow into: the others stay 0.

    Returns
    -------
    ndarray of shape (h, w), uint8
        1 on the grown subject; it holds `subject`.
    """
    allowed = within_bounds(subject.shape, bounds)
    lab = cv2.cvtColor(bgr, cv2.COLOR_BGR2LAB).astype(np.float32)
    # The window sums of 1, the colour and its square norm, over the subject or the ring.
    features = np.dstack([np.ones(lab.shape[:2], np.float32), lab, np.sum(lab**2, axis=2)])
    grown = subject.astype(np.uint8)
    joined = grown > 0
    # Only the pixels near those that joined last can join next: a round works on their box,
    # grown by what decides them (the step, the ring and the window).
    margin = int(np.ceil(GROWTH_STEP + GROWTH_RING)) + GROWTH_WINDOW + 1
    reach = 2 * int(GROWTH_STEP + 1) + 1
    nearby = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (reach, reach))
    for _ in range(GROWTH_ROUNDS):
        rows, columns = np.nonzero(joined)
        if not len(rows):
            break
        box = (
            slice(max(rows.min() - margin, 0), rows.max() + margin + 1),
            slice(max(columns.min() - margin, 0), columns.max() + margin + 1),
        )
        near = cv2.dilate(joined[box].astype(np.uint8), nearby) > 0
        joining = _joining(features[box], grown[box], allowed[box] & near)
        grown[box][joining] = 1
        joined = np.zeros(grown.shape, bool)
        joined[box] = joining
    return grown


def _joining(features: np.ndarray, subject: np.ndarray, allowed: np.ndarray) -> np.ndarray:
    """The pixels that join the `subject` (h, w) uint8 in one round: bool (h, w).

    Those within `GROWTH_STEP` outside it and `allowed` (h, w) bool whose colour costs
    less under the subject's local colours (more than a pixel inside its outline) than
    under the background's (the ring from `GROWTH_STEP` to `GROWTH_RING` outside it);
    `features` (h, w, 5) as `_local_cost` takes them.
    """
    outside = cv2.distanceTransform(1 - subject, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    # More than a pixel inside: all four neighbours are subject.
    inside = cv2.erode(subject, cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3)), borderValue=1) > 0
    candidates = np.flatnonzero((outside > 0) & (outside <= GROWTH_STEP) & allowed)
    ring = (outside > GROWTH_STEP) & (outside <= GROWTH_RING)
    colours = features.reshape(-1, 5)[candidates, 1:4]
    joining = np.zeros(subject.size, bool)
    subject_cost = _local_cost(features, inside, candidates, colours)
    background_cost = _local_cost(features, ring, candidates, colours)
    joining[candidates] = subject_cost < background_cost
    return joining.reshape(subject.shape)


def _local_cost(
    features: np.ndarray, where: np.ndarray, pixels: np.ndarray, colours: np.ndarray
) -> np.ndarray:
    """How badly the colours of `where` near each of `pixels` explain its colour: float (K,).

    `features` (h, w, 5) holds 1, the CIELAB colour and its squared norm of every pixel;
    `where` (h, w) bool; `pixels` (K,) are flat indices and `colours` (K, 3) their colours.
    The colours of the pixels `where` within a square window of half-width
    `GROWTH_WINDOW` (a box filter: its cost does not grow with the window) have a local
    mean m and variance v (per channel, averaged over the three, at least
    `GROWTH_VARIANCE`); the cost of a colour c is the negative log-likelihood of an
    isotropic Gaussian, |c - m|^2 / v + 3 log v (up to a constant); infinite where no
    pixel of the window is `where`.
    """
    size = (2 * GROWTH_WINDOW + 1,) * 2
    sums = cv2.boxFilter(features * where[..., None], -1, size, normalize=False).reshape(-1, 5)[pixels]
    count = sums[:, 0]
    mean = sums[:, 1:4] / np.maximum(count, 1)[:, None]
    variance = np.maximum((sums[:, 4] / np.maximum(count, 1) - np.sum(mean**2, axis=1)) / 3, GROWTH_VARIANCE)
    cost = np.sum((colours - mean) ** 2, axis=1) / variance + 3 * np.log(variance)
    return np.where(count >= 1, cost, np.inf)
