"""What tells a photograph's subject from its background, for `app.fit.subject`: colour and focus.

`border_contrast` scores each pixel by how badly a colour model of the image's border
explains it; `in_focus` finds the sharp part of a picture with a shallow depth of
field; `boundary_saliency` is the geodesic distance of each pixel to the border
through colour changes (Wei et al. 2012).  `colour_model` and `log_likelihood` are
the small Gaussian mixtures these and `app.fit.doubt.colour_separation` share.  Arrays are
(H, W) images, row 0 at the top.
"""

from __future__ import annotations

import cv2
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

#: Without a rectangle, the frame of this fraction of each side is background.
DEFAULT_INSET = 0.03


#: A pixel is probably subject when the border's colour model (`border_contrast`) finds it
#: this much less likely (natural logarithm: 400 times) than the least likely 5 % of the
#: frame's own pixels.
BORDER_CONTRAST = 6.0


#: A colour model is learned from at least this many pixels of each side (GrabCut's
#: mixtures have five components): fewer, and the refinement and `colour_separation` give up.
MIN_SAMPLES = 50


#: The border's colour model is learned from at most about this many pixels of the rest.
MODEL_SAMPLES = 2000


#: `in_focus`: the detail is averaged over a Gaussian of this many pixels (of the copy of
#: `REFINE_PIXELS`); the depth of field is shallow when the frame's median detail is below
#: `FOCUS_RATIO` of the centre's (measured: chelsea 0.27, astronaut 0.25, coffee 1.00, the
#: synthetic scenes 0.75 to 1.91), and a pixel is in focus above `FOCUS_LEVEL` of the
#: centre's upper quartile (on GrabCut's copy).
FOCUS_WINDOW = 4.0


FOCUS_RATIO = 0.5


FOCUS_LEVEL = 0.25


#: The boundary saliency (`boundary_saliency`) is computed on a copy of this longer side.
SALIENCY_SIDE = 96


def border_contrast(bgr: np.ndarray) -> np.ndarray:
    """Pixels whose colour the image's border does not explain: bool (h, w).

    Most photographs are framed with background all around the subject.  A Gaussian
    mixture of the colours of the frame of `DEFAULT_INSET` of each side is learned
    (GrabCut's own five components, `colour_model`); a pixel whose negative log-likelihood
    under it exceeds the frame's own 95th percentile by `BORDER_CONTRAST` is
    probably subject, as a saucer whose red is close to its wooden table's but not
    the same, which the geodesic `boundary_saliency` misses where a dark rim does
    not part them.

    Parameters
    ----------
    bgr : ndarray of shape (h, w, 3), uint8
        The picture, BGR.
    """
    frame = frame_mask(bgr.shape[:2])
    if frame.all():  # a picture of a few pixels is all border
        return np.zeros(frame.shape, bool)
    model = colour_model(bgr[frame], bgr[~frame])
    surprise = -log_likelihood(model, bgr)
    return surprise > np.percentile(surprise[frame], 95) + BORDER_CONTRAST


def in_focus(fine: np.ndarray, coarse: np.ndarray) -> np.ndarray | None:
    """The sharp part of a photograph with a shallow depth of field: bool (h, w), or None.

    The detail of a pixel is the root mean square, over a Gaussian window of
    `FOCUS_WINDOW` pixels, of the grey levels less their Gaussian blur of one pixel:
    what a defocused background lacks.  The depth of field is shallow when, on the
    finer copy, the median detail of the border frame (`DEFAULT_INSET`) is below
    `FOCUS_RATIO` of that of the central quarter of the picture (half its width and
    height); then the pixels of the coarser copy whose detail there exceeds
    `FOCUS_LEVEL` of the centre's upper quartile are in focus (at that scale a part of
    the subject a little soft, as an ear behind the eyes, still has detail).  Otherwise
    None: sharpness says nothing about the subject (a sharp table under a smooth cup,
    an evenly textured scene).

    Parameters
    ----------
    fine : ndarray of shape (H, W, 3), uint8
        The picture, RGB, on the finer copy.
    coarse : ndarray of shape (h, w, 3), uint8
        The same picture on a coarser copy.
    """
    detail = _detail(fine)
    if np.median(detail[frame_mask(detail.shape)]) >= FOCUS_RATIO * np.median(_centre(detail)):
        return None
    detail = _detail(coarse)
    return detail > FOCUS_LEVEL * np.percentile(_centre(detail), 75)


def _detail(rgb: np.ndarray) -> np.ndarray:
    """The detail of `in_focus` of the picture `rgb` (h, w, 3) uint8: float32 (h, w)."""
    grey = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY).astype(np.float32)
    fine = grey - cv2.GaussianBlur(grey, (0, 0), 1.0)
    return np.sqrt(cv2.GaussianBlur(fine**2, (0, 0), FOCUS_WINDOW))


def _centre(values: np.ndarray) -> np.ndarray:
    """The central quarter (half the height and width) of `values` (h, w)."""
    height, width = values.shape
    return values[height // 4 : height - height // 4, width // 4 : width - width // 4]


def frame_mask(shape: tuple[int, int]) -> np.ndarray:
    """The frame of `DEFAULT_INSET` of each side (at least a pixel) of `shape` (h, w): bool (h, w)."""
    height, width = shape
    inset = max(1, round(DEFAULT_INSET * min(height, width)))
    frame = np.ones(shape, bool)
    frame[inset:-inset, inset:-inset] = False
    return frame


def colour_model(samples: np.ndarray, others: np.ndarray) -> np.ndarray:
    """GrabCut's Gaussian mixture of the colours `samples` (N, 3) BGR uint8: float64 (65,).

    Learned as GrabCut learns its background model (k-means with OpenCV's generator
    seeded, then the components' weights, means and covariances), from a column of
    pixels; GrabCut needs some of the other side too, `others` (M, 3), M > 0, of which
    at most about `MODEL_SAMPLES` are given.  Layout: 5 weights, 5 x 3 means, 5 x 3 x 3
    covariances.
    """
    others = others[:: max(1, len(others) // MODEL_SAMPLES)]
    column = np.ascontiguousarray(np.concatenate([samples, others])[:, None, :])
    sides = np.repeat(np.uint8([cv2.GC_BGD, cv2.GC_FGD]), [len(samples), len(others)])[:, None]
    cv2.setRNGSeed(0)
    models = np.zeros((1, 65)), np.zeros((1, 65))
    cv2.grabCut(column, sides, None, *models, 0, cv2.GC_INIT_WITH_MASK)
    return models[0][0]


def log_likelihood(model: np.ndarray, bgr: np.ndarray) -> np.ndarray:
    """Log-density (h, w) of the colours of `bgr` (h, w, 3) under the mixture `model` (65,).

    `model` is laid out as `colour_model` returns it.

    Each covariance gets 0.01 on its diagonal, as in GrabCut, so that a component of
    nearly one colour stays regular.
    """
    weights, means, covariances = model[:5], model[5:20].reshape(5, 3), model[20:].reshape(5, 3, 3)
    colours = bgr.reshape(-1, 3).astype(np.float64)
    density = np.zeros(len(colours))
    for k in np.flatnonzero(weights > 0):
        covariance = covariances[k] + 0.01 * np.eye(3)
        offset = colours - means[k]
        distance = np.einsum("ni,ij,nj->n", offset, np.linalg.inv(covariance), offset)
        scale = np.sqrt((2 * np.pi) ** 3 * np.linalg.det(covariance))
        density += weights[k] * np.exp(-0.5 * distance) / scale
    return np.log(np.maximum(density, 1e-300)).reshape(bgr.shape[:2])


def boundary_saliency(image: np.ndarray) -> np.ndarray:
    """How far each pixel is from the image's border in colour, float32 (H, W) in [0, 1].

    Geodesic saliency with the boundary prior (Wei, Wen, Zhu and Sun, "Geodesic
    saliency using background priors", ECCV 2012): background regions reach the
    border through pixels of similar colour, a subject is cut off from it by its
    outline.  On a copy of longer side `SALIENCY_SIDE`, lightly blurred, a step
    between 4-neighbours costs their CIELAB difference less the median step (so
    that texture does not add up), and the distance from each of the four sides
    is computed separately (Dijkstra).  The second smallest of the four is kept,
    so that a subject may touch one side, as a portrait its bottom edge.

    Parameters
    ----------
    image : ndarray of shape (H, W, 3), uint8
        RGB, row 0 at the top.
    """
    height, width = image.shape[:2]
    factor = SALIENCY_SIDE / max(height, width)
    size = (max(2, round(width * factor)), max(2, round(height * factor)))
    small = cv2.GaussianBlur(cv2.resize(image, size, interpolation=cv2.INTER_AREA), (0, 0), 1.0)
    lab = cv2.cvtColor(small, cv2.COLOR_RGB2LAB).reshape(-1, 3).astype(np.float32)
    index = np.arange(size[0] * size[1]).reshape(size[1], size[0])
    first = np.concatenate([index[:, :-1].ravel(), index[:-1, :].ravel()])
    second = np.concatenate([index[:, 1:].ravel(), index[1:, :].ravel()])
    step = np.linalg.norm(lab[first] - lab[second], axis=1)
    # A small floor keeps every edge in the sparse graph (a zero weight would drop it).
    cost = np.maximum(step - np.median(step), 0) + 1e-3
    graph = coo_matrix((cost, (first, second)), shape=(index.size, index.size)).tocsr()
    sides = (index[0], index[-1], index[:, 0], index[:, -1])
    distances = np.stack([dijkstra(graph, directed=False, indices=side, min_only=True) for side in sides])
    distances /= np.maximum(distances.max(axis=1, keepdims=True), 1e-12)
    saliency = np.sort(distances, axis=0)[1].reshape(size[1], size[0]).astype(np.float32)
    saliency = cv2.resize(saliency, (width, height), interpolation=cv2.INTER_LINEAR)
    return saliency / max(float(saliency.max()), 1e-12)
