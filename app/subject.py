"""The main subject of an image (`subject_mask`), the mask `app.fit` fits its cage around.

The subject is, in this order of trust:

- the alpha channel, when the image has one that is not all opaque;
- a silhouette on a plain background, when the grey levels are two-toned (Otsu's
  threshold explains at least `TWO_TONE` of their variance): the largest object of
  that threshold, in the polarity in which it does not touch the border;
- otherwise a photograph: GrabCut (Rother, Kolmogorov and Blake 2004) on a copy of
  about `SEGMENT_PIXELS` pixels.  Outside the rectangle is background; inside it
  the probable subject is seeded by the geodesic boundary saliency
  (`boundary_saliency`) and by the colours that the border does not explain
  (`border_contrast`); when the depth of field is shallow (`in_focus`), only what
  is in focus, and the subject may then run into the border.
  Of what GrabCut keeps, the largest and most central region is taken, its holes
  filled and its outline smoothed; then the band along its outline is decided
  anew on a finer copy (`refined_subject`), from the colours of the subject's core
  and of the background next to it, and holes and bays with a narrow mouth
  (a dark collar between a face and a suit) are filled.

How well colour tells a photograph's subject from the background around it is
`colour_separation`.  Coordinates are image pixels, x right, y down, origin at the
image's top-left corner; pixel (column i, row j) covers [i, i+1] x [j, j+1].  A
rectangle is (x, y, width, height) in the same pixels.
"""

from __future__ import annotations

import cv2
import numpy as np
from scipy.ndimage import minimum
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

#: Share of the grey levels' variance that Otsu's two classes must explain for an
#: opaque image to count as a silhouette on a plain background (antialiased
#: silhouettes: above 0.97; photographs of scikit-image's data: 0.57 to 0.86).
TWO_TONE = 0.92
#: GrabCut runs on a copy of about this many pixels (256 x 256): its cost grows with
#: the pixels, and a cage of a few dozen control points needs no finer outline.
SEGMENT_PIXELS = 1 << 15
#: GrabCut's rounds of colour models and graph cut.
GRABCUT_ITERATIONS = 4
#: Without a rectangle, the frame of this fraction of each side is background.
DEFAULT_INSET = 0.03
#: The boundary saliency (`boundary_saliency`) is computed on a copy of this longer side.
SALIENCY_SIDE = 96
#: Without a rectangle, GrabCut's rectangle is the box of the central region salient above
#: this fraction of the saliency's Otsu threshold, grown by `RECT_GROWTH` of its longer side.
RECT_LEVEL = 0.5
RECT_GROWTH = 0.08
#: Inside the rectangle, pixels salient above this fraction of the Otsu threshold seed
#: the probable subject, the others the probable background.
SEED_LEVEL = 0.25
#: A subject of less than this share of the rectangle is a detail (an eye of a close-up
#: face): GrabCut starts again from the rectangle alone, and the larger result is kept.
MIN_SUBJECT = 0.05
#: The larger result of that second run is kept only if it stands out from the background
#: next to it (`_stands_out`): on scikit-image's rocket the first run keeps the rocket (2 %),
#: the second the sky beside it, no more salient than the sky around that.
#: Other parts of GrabCut's result join the main one when at least this share of its
#: area and closer than `MERGE_GAP` of the rectangle's diagonal (`_central_component`).
MERGE_AREA = 0.1
MERGE_GAP = 0.15
#: A pixel is probably subject when the border's colour model (`border_contrast`) finds it
#: this much less likely (natural logarithm: 400 times) than the least likely 5 % of the
#: frame's own pixels.
BORDER_CONTRAST = 6.0
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
#: Opening and closing of GrabCut's mask, as a fraction of the rectangle's shorter side.
SMOOTHING = 0.02
#: GrabCut's outline is refined (`refined_subject`) on a copy of about this many pixels
#: (362 x 362): twice as fine as `SEGMENT_PIXELS` in each direction.
REFINE_PIXELS = 1 << 17
#: Half the width of the band of the outline that the refinement decides anew, as a
#: fraction of the square root of the subject's area (5.7 % of the side of a square).
REFINE_BAND = 0.1
#: The background's colours are learned out to this many band widths from the outline.
REFINE_RING = 3
#: Rounds of the refinement: each can move the outline by one band width.
REFINE_ROUNDS = 2
#: The refinement needs this many pixels of the core and of the ring to learn its models
#: (GrabCut's mixtures have five components).
MIN_SAMPLES = 50
#: Holes and bays of the subject whose mouth is narrower than twice this fraction of the
#: square root of its area are filled (`bays_filled`): a portrait's dark collar ring,
#: left out by its colour, is part of the subject; an L's open corner stays open.
BAY_MOUTH = 0.15


def subject_mask(image: np.ndarray, rect=None) -> np.ndarray:
    """The main subject of the image, bool ndarray of shape (H, W), without the cage's margin.

    `fit_cage` fits its cage around this mask (computed on its working copy).

    Parameters
    ----------
    image : ndarray of shape (H, W, 4) or (H, W, 3), uint8
        RGBA or RGB, row 0 at the top.
    rect : sequence of 4 numbers (x, y, width, height), optional
        As in `fit_cage`: nothing outside it is part of the subject.

    Raises
    ------
    ValueError
        If the image or the rectangle is invalid, or no subject is found.
    """
    image = checked_image(image)
    mask = find_subject(image, checked_rect(rect, image.shape[1], image.shape[0]))[0]
    if mask is None:
        raise ValueError("found no subject inside the rectangle")
    return mask


def checked_rect(rect, width: int, height: int) -> np.ndarray | None:
    """`rect` as float64 (x, y, width, height), shape (4,), or None; `ValueError` unless inside the image.

    The rectangle must have a positive width and height and lie within the
    `width` x `height` image (x right, y down, origin at the top-left corner).
    """
    if rect is None:
        return None
    try:
        values = np.array(rect, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"rect must be four numbers x, y, width, height, got {rect!r}") from None
    if values.shape != (4,) or not np.isfinite(values).all():
        raise ValueError(f"rect must be four finite numbers x, y, width, height, got {rect!r}")
    x, y, w, h = values
    if w <= 0 or h <= 0:
        raise ValueError(f"rect must have a positive width and height, got {w:g}x{h:g}")
    if x < 0 or y < 0 or x + w > width or y + h > height:
        raise ValueError(
            f"rect reaches outside the {width}x{height} image: it spans x {x:g} to {x + w:g} "
            f"and y {y:g} to {y + h:g}"
        )
    return values


def downscaled(image: np.ndarray, max_pixels: int) -> tuple[np.ndarray, np.ndarray]:
    """`image` (H, W, C) shrunk by area averaging to at most `max_pixels` pixels.

    Returns the copy (h, w, C) (the image itself if small enough) and the scale
    (W / w, H / h), shape (2,), that maps its pixel coordinates (x right, y down,
    origin at the top-left corner) back to the image's.
    """
    height, width = image.shape[:2]
    if height * width <= max_pixels:
        return image, np.ones(2)
    factor = np.sqrt(max_pixels / (height * width))
    size = (max(1, int(width * factor)), max(1, int(height * factor)))
    small = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
    return small, np.array([width / size[0], height / size[1]])


def silhouette_mask(image: np.ndarray) -> np.ndarray:
    """The main object of a silhouette image, bool ndarray of shape (H, W).

    The alpha channel decides when it is present and not all opaque; otherwise
    the object is the largest component of an Otsu threshold, taking the polarity
    (dark or light object) whose largest component does not touch the border.
    """
    image = checked_image(image)
    if image.shape[2] == 4 and image[..., 3].min() < 255:
        candidates = [_largest_component(image[..., 3] >= 128)]
    else:
        grey = _grey(image)
        _, light = cv2.threshold(grey, 0, 1, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
        size = max(3, (min(image.shape[:2]) // 200) | 1)
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
        candidates = []
        for mask in (light, 1 - light):
            mask = cv2.morphologyEx(mask.astype(np.uint8), cv2.MORPH_OPEN, kernel)
            mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, kernel)
            candidates.append(_largest_component(mask > 0, avoid_border=True))
    touches, area, mask = max(candidates, key=lambda c: (not c[0], c[1]))
    if area < 16:
        raise ValueError("found no object in the image (the silhouette is empty or tiny)")
    return mask


def two_toned(image: np.ndarray) -> bool:
    """Whether Otsu's threshold explains at least `TWO_TONE` of the grey levels' variance.

    `image` is (H, W, C) uint8, C >= 3.  True for a silhouette on a plain
    background, false for a photograph (and for a constant image).
    """
    grey = _grey(image)
    threshold, _ = cv2.threshold(grey, 0, 1, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    histogram = np.bincount(grey.ravel(), minlength=256).astype(np.float64)
    levels = np.arange(256.0)
    light = levels > threshold
    count, total = histogram.sum(), histogram[light].sum()
    variance = histogram @ levels**2 / count - (histogram @ levels / count) ** 2
    if total in (0, count) or variance <= 0:
        return False
    mean_light = histogram[light] @ levels[light] / total
    mean_dark = histogram[~light] @ levels[~light] / (count - total)
    between = total / count * (1 - total / count) * (mean_light - mean_dark) ** 2
    return bool(between >= TWO_TONE * variance)


def photo_subject(image: np.ndarray, rect=None) -> np.ndarray:
    """The main subject of a photograph by GrabCut, bool ndarray of shape (H, W).

    Parameters
    ----------
    image : ndarray of shape (H, W, C), uint8, C >= 3
        RGB(A), row 0 at the top; the alpha channel is ignored.
    rect : ndarray of shape (4,), optional
        (x, y, width, height) inside the image (`checked_rect`); nothing outside it is
        the subject.  Default: the box of the central salient region, grown by
        `RECT_GROWTH`, within all but a frame of `DEFAULT_INSET` of each side.

    Notes
    -----
    GrabCut runs on a copy of about `SEGMENT_PIXELS` pixels, with OpenCV's random
    generator seeded so that a photograph always gives the same cage.  Outside the
    rectangle is background; inside, the pixels whose `boundary_saliency` exceeds
    `SEED_LEVEL` of its Otsu threshold and those of `border_contrast` are probable
    subject, the others probable background.  When the depth of field is shallow
    (`in_focus` is not None), only the probable subject in focus stays so, and
    without a rectangle the whole picture is considered, its frame of `DEFAULT_INSET`
    background except where it is probable subject (a close-up runs into the
    border; its out-of-focus surroundings are the background).  The result is
    opened, its most central large component kept
    (`_central_component`), its holes filled and closed.  A result smaller than
    `MIN_SUBJECT` of the rectangle is a detail: GrabCut runs again from the
    rectangle alone (all of it probable subject; with a shallow depth of field and no
    rectangle, all but the frame's background) and the larger result is kept: on
    scikit-image's chelsea the first run keeps an eye (3 % of the picture), the second
    the head and both ears.
    That result is scaled to a copy of about `REFINE_PIXELS` pixels, refined there
    (`refined_subject`, nothing outside the rectangle), its holes and narrow-mouthed
    bays filled (`bays_filled`), and scaled back to (H, W), each time by bilinear
    interpolation of the 0/1 mask.
    """
    height, width = image.shape[:2]
    small, scale = downscaled(np.ascontiguousarray(image[..., :3]), SEGMENT_PIXELS)
    saliency = np.round(255 * boundary_saliency(small)).astype(np.uint8)
    otsu, _ = cv2.threshold(saliency, 0, 1, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    if rect is None:
        bounds = _salient_bounds(saliency > RECT_LEVEL * otsu)
    else:
        bounds = _pixel_bounds(np.asarray(rect) / np.tile(scale, 2), small.shape[:2])
    left, top, right, bottom = bounds
    inside = (slice(top, bottom), slice(left, right))
    bgr = np.ascontiguousarray(small[..., ::-1])
    probable = (saliency > SEED_LEVEL * otsu) | border_contrast(bgr)
    fine, fine_scale = downscaled(np.ascontiguousarray(image[..., :3]), REFINE_PIXELS)
    sharp = in_focus(fine, small)
    seeds = np.full(small.shape[:2], cv2.GC_BGD, np.uint8)
    if sharp is not None:
        # A shallow depth of field: what is out of focus is background.
        probable &= sharp
    if sharp is not None and rect is None:
        # A subject in focus may run into the border (a close-up's ears): the frame is
        # background only where it is not probable subject.
        bounds = left, top, right, bottom = 0, 0, small.shape[1], small.shape[0]
        inside = (slice(top, bottom), slice(left, right))
        seeds[~_frame(small.shape[:2])] = cv2.GC_PR_BGD
    else:
        seeds[inside] = cv2.GC_PR_BGD
    seeds[inside] = np.where(probable[inside], cv2.GC_PR_FGD, seeds[inside])
    subject = _grabcut_region(bgr, seeds, bounds)
    if subject.sum() < MIN_SUBJECT * (right - left) * (bottom - top):
        seeds = np.where(seeds == cv2.GC_BGD, seeds, cv2.GC_PR_FGD).astype(np.uint8)
        larger = _grabcut_region(bgr, seeds, bounds)
        if larger.sum() > subject.sum() and (_stands_out(saliency, larger) or not subject.any()):
            subject = larger
    subject = _resized(subject, fine.shape[:2])
    limits = (0, 0, fine.shape[1], fine.shape[0])
    if rect is not None:
        limits = _pixel_bounds(np.asarray(rect) / np.tile(fine_scale, 2), fine.shape[:2])
    subject = refined_subject(np.ascontiguousarray(fine[..., ::-1]), subject, limits)
    subject = bays_filled(subject, limits)
    return _resized(subject, (height, width)) > 0


def _stands_out(saliency: np.ndarray, subject: np.ndarray) -> bool:
    """Whether `subject` (h, w) uint8 is more salient on average than the background around it.

    The background around it is the ring from 1 to `REFINE_RING` band widths
    (`REFINE_BAND` sqrt(area)) outside its outline; `saliency` is (h, w), uint8 or float.
    """
    inside, ring = subject > 0, _ring(subject)
    return bool(ring.any() and saliency[inside].mean() > saliency[ring].mean())


def _ring(subject: np.ndarray) -> np.ndarray:
    """The background around `subject` (h, w) uint8: bool (h, w), out to `REFINE_RING` band widths."""
    band = max(2.0, REFINE_BAND * np.sqrt(float(subject.sum())))
    outside = cv2.distanceTransform((subject == 0).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    return (outside > 0) & (outside <= REFINE_RING * band)


def colour_separation(image: np.ndarray, subject: np.ndarray) -> float:
    """How well colour tells the subject from the background around it, in [0, 1] (0.5: not at all).

    GrabCut's Gaussian mixtures (`_colour_model`) are learned from the subject's
    pixels and from the ring of background around it (`_ring`); the result is the
    mean of the share of subject pixels more likely under the subject's model and
    the share of ring pixels more likely under the background's.  Computed on a
    copy of about `SEGMENT_PIXELS` pixels.

    Parameters
    ----------
    image : ndarray of shape (H, W, C), uint8, C >= 3
        RGB(A), row 0 at the top.
    subject : ndarray of shape (H, W), bool
    """
    small, _ = downscaled(np.ascontiguousarray(image[..., :3]), SEGMENT_PIXELS)
    inside = _resized(subject, small.shape[:2])
    ring = _ring(inside)
    inside = inside > 0
    if inside.sum() < MIN_SAMPLES or ring.sum() < MIN_SAMPLES:
        return 0.5
    bgr = np.ascontiguousarray(small[..., ::-1])
    subject_model, background_model = (
        _colour_model(bgr[inside], bgr[ring]),
        _colour_model(bgr[ring], bgr[inside]),
    )
    closer = _log_likelihood(subject_model, bgr) > _log_likelihood(background_model, bgr)
    return float(0.5 * (closer[inside].mean() + (~closer[ring]).mean()))


def border_contrast(bgr: np.ndarray) -> np.ndarray:
    """Pixels whose colour the image's border does not explain: bool (h, w).

    Most photographs are framed with background all around the subject.  A Gaussian
    mixture of the colours of the frame of `DEFAULT_INSET` of each side is learned
    (GrabCut's own five components, `_colour_model`); a pixel whose negative log-likelihood
    under it exceeds the frame's own 95th percentile by `BORDER_CONTRAST` is
    probably subject, as a saucer whose red is close to its wooden table's but not
    the same, which the geodesic `boundary_saliency` misses where a dark rim does
    not part them.

    Parameters
    ----------
    bgr : ndarray of shape (h, w, 3), uint8
        The picture, BGR.
    """
    frame = _frame(bgr.shape[:2])
    if frame.all():  # a picture of a few pixels is all border
        return np.zeros(frame.shape, bool)
    model = _colour_model(bgr[frame], bgr[~frame])
    surprise = -_log_likelihood(model, bgr)
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
    if np.median(detail[_frame(detail.shape)]) >= FOCUS_RATIO * np.median(_centre(detail)):
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


def _frame(shape: tuple[int, int]) -> np.ndarray:
    """The frame of `DEFAULT_INSET` of each side (at least a pixel) of `shape` (h, w): bool (h, w)."""
    height, width = shape
    inset = max(1, round(DEFAULT_INSET * min(height, width)))
    frame = np.ones(shape, bool)
    frame[inset:-inset, inset:-inset] = False
    return frame


def _colour_model(samples: np.ndarray, others: np.ndarray) -> np.ndarray:
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


def _log_likelihood(model: np.ndarray, bgr: np.ndarray) -> np.ndarray:
    """Log-density (h, w) of the colours of `bgr` (h, w, 3) under the mixture `model` (65,).

    `model` is laid out as `_colour_model` returns it.

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


def refined_subject(
    bgr: np.ndarray, subject: np.ndarray, bounds: tuple[int, int, int, int], rounds: int = REFINE_ROUNDS
) -> np.ndarray:
    """GrabCut's `subject` (h, w) uint8 decided anew near its outline from local colour models.

    GrabCut learns the subject's colours from everything seeded as probable subject,
    which on a busy background (gravel, foliage) includes a halo around the subject;
    the learned model then keeps a band of background all around it.  Here the
    subject's colours are learned from its core only (`subject` eroded by the band
    half-width b = `REFINE_BAND` sqrt(area)), the background's from the ring between
    b and `REFINE_RING` b outside the outline (within `bounds`), so from the
    background next to the subject rather than from distant parts of the picture
    that may share its colours.  With these models frozen, one graph cut (OpenCV's
    ``GC_EVAL_FREEZE_MODEL``) decides the band within b of the outline; the result is
    cleaned up as in `_grabcut_region`.  `rounds` such rounds are made.

    Parameters
    ----------
    bgr : ndarray of shape (h, w, 3), uint8
        The picture, BGR.
    subject : ndarray of shape (h, w), uint8
        1 on the subject.
    bounds : (left, top, right, bottom)
        The pixels that may belong to the subject (the rectangle); `subject` is cut to them.

    Returns
    -------
    ndarray of shape (h, w), uint8
        1 on the subject; `subject` itself when it is too thin to have a core.
    """
    left, top, right, bottom = bounds
    allowed = np.zeros(subject.shape, bool)
    allowed[top:bottom, left:right] = True
    subject = np.where(allowed, subject, 0).astype(np.uint8)
    for _ in range(rounds):
        band = max(2, round(REFINE_BAND * np.sqrt(float(subject.sum()))))
        # Distances cost the same for any band, an erosion or dilation by a disk grows with it.
        inside = cv2.distanceTransform(subject, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        outside = cv2.distanceTransform(1 - subject, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        core = inside > band
        outer = (outside <= band) & allowed
        ring = (outside <= REFINE_RING * band) & ~outer & allowed
        if core.sum() < MIN_SAMPLES or ring.sum() < MIN_SAMPLES:
            break
        # GrabCut learns its models from every pixel of the image it is given: give it the
        # core and the ring alone, as a column of pixels.
        samples = np.ascontiguousarray(np.concatenate([bgr[core], bgr[ring]])[:, None, :])
        sides = np.repeat(np.uint8([cv2.GC_FGD, cv2.GC_BGD]), [core.sum(), ring.sum()])[:, None]
        cv2.setRNGSeed(0)
        models = np.zeros((1, 65)), np.zeros((1, 65))
        cv2.grabCut(samples, sides, None, *models, 0, cv2.GC_INIT_WITH_MASK)
        labels = np.where(subject > 0, cv2.GC_PR_FGD, cv2.GC_PR_BGD).astype(np.uint8)
        labels[~outer] = cv2.GC_BGD
        labels[core] = cv2.GC_FGD
        # Only the band is undecided: the graph cut runs on its box, a pixel wider.
        x, y, w, h = cv2.boundingRect(outer.astype(np.uint8))
        box = slice(max(y - 1, 0), y + h + 1), slice(max(x - 1, 0), x + w + 1)
        cut = np.ascontiguousarray(labels[box])
        cv2.grabCut(np.ascontiguousarray(bgr[box]), cut, None, *models, 1, cv2.GC_EVAL_FREEZE_MODEL)
        found = np.zeros_like(subject)
        found[box] = (cut == cv2.GC_FGD) | (cut == cv2.GC_PR_FGD)
        x, y, w, h = cv2.boundingRect(subject)
        subject = _cleaned(found, (x, y, x + w, y + h))
        if not subject.any():
            break
    return subject


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


def find_subject(image: np.ndarray, rect: np.ndarray | None) -> tuple[np.ndarray | None, bool]:
    """(mask (H, W) bool, whether it is exact): the subject of a checked image inside `rect`.

    With a rectangle in which nothing is found (a texture, an empty patch) the mask is
    None; without one, that raises `ValueError`.
    """
    height, width = image.shape[:2]
    left, top, right, bottom = (0, 0, width, height) if rect is None else _pixel_bounds(rect, (height, width))
    crop = image[top:bottom, left:right]
    if (crop.shape[2] == 4 and crop[..., 3].min() < 255) or two_toned(crop):
        try:
            found = silhouette_mask(crop)
        except ValueError:
            if rect is None:
                raise
            return None, True
        mask = np.zeros((height, width), dtype=bool)
        mask[top:bottom, left:right] = found
        return mask, True
    mask = photo_subject(image, rect)
    if mask.sum() >= 16:
        return mask, False
    if rect is None:
        raise ValueError("found no subject in the image (GrabCut kept nothing); give a rectangle around it")
    return None, False


def checked_image(image: np.ndarray) -> np.ndarray:
    image = np.asarray(image)
    if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] not in (3, 4):
        raise ValueError(
            f"image must be an (H, W, 3) or (H, W, 4) uint8 array, got {image.dtype} {image.shape}"
        )
    if min(image.shape[:2]) < 2:
        raise ValueError(f"image must be at least 2x2 pixels, got {image.shape[1]}x{image.shape[0]}")
    return image


def _grey(image: np.ndarray) -> np.ndarray:
    """Lightly blurred grey levels (H, W) uint8 of an RGB(A) image."""
    return cv2.GaussianBlur(cv2.cvtColor(np.ascontiguousarray(image[..., :3]), cv2.COLOR_RGB2GRAY), (5, 5), 0)


def _pixel_bounds(rect: np.ndarray, shape: tuple[int, int]) -> tuple[int, int, int, int]:
    """(left, top, right, bottom): the pixels of `shape` (H, W) that `rect` (x, y, w, h) touches."""
    height, width = shape
    left = min(max(int(np.floor(rect[0])), 0), width - 1)
    top = min(max(int(np.floor(rect[1])), 0), height - 1)
    right = max(min(int(np.ceil(rect[0] + rect[2])), width), left + 1)
    bottom = max(min(int(np.ceil(rect[1] + rect[3])), height), top + 1)
    return left, top, right, bottom


def _salient_bounds(salient: np.ndarray) -> tuple[int, int, int, int]:
    """(left, top, right, bottom) of the default rectangle around the salient mask (h, w).

    The box of its most central large component grown by `RECT_GROWTH`, within the
    image less a frame of `DEFAULT_INSET`; that frame alone if nothing is salient.
    """
    height, width = salient.shape
    inset = DEFAULT_INSET * np.array([width, height])
    low, high = np.ceil(inset).astype(int), np.floor([width, height] - inset).astype(int)
    high = np.maximum(high, low + 1)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5))
    region = _central_component(
        cv2.morphologyEx(salient.astype(np.uint8), cv2.MORPH_CLOSE, kernel),
        0.5 * np.array([width, height]),
        np.array([width, height]),
    )
    if not region.any():
        return int(low[0]), int(low[1]), int(high[0]), int(high[1])
    x, y, w, h = cv2.boundingRect(region)
    growth = RECT_GROWTH * max(w, h)
    left, top = np.minimum(np.maximum(low, np.floor([x - growth, y - growth])), high - 1).astype(int)
    right, bottom = np.maximum(
        np.minimum(high, np.ceil([x + w + growth, y + h + growth])), [left + 1, top + 1]
    )
    return int(left), int(top), int(right), int(bottom)


def _grabcut_region(bgr: np.ndarray, seeds: np.ndarray, bounds: tuple[int, int, int, int]) -> np.ndarray:
    """GrabCut of `bgr` (h, w, 3) from `seeds` (h, w), cleaned up: uint8 (h, w), 1 on the subject.

    Nothing (all 0) when the seeds lack either side, from which GrabCut learns its colours
    (a rectangle of a pixel or two on GrabCut's copy).
    """
    subject = (seeds == cv2.GC_FGD) | (seeds == cv2.GC_PR_FGD)
    if subject.all() or not subject.any():
        return np.zeros(seeds.shape, np.uint8)
    labels = seeds.copy()
    cv2.setRNGSeed(0)  # GrabCut's k-means starts from OpenCV's global random generator
    models = np.zeros((1, 65)), np.zeros((1, 65))
    cv2.grabCut(bgr, labels, None, *models, GRABCUT_ITERATIONS, cv2.GC_INIT_WITH_MASK)
    found = ((labels == cv2.GC_FGD) | (labels == cv2.GC_PR_FGD)).astype(np.uint8)
    return _cleaned(found, bounds)


def _cleaned(found: np.ndarray, bounds: tuple[int, int, int, int]) -> np.ndarray:
    """GrabCut's `found` (h, w) uint8 opened, its main region (`_central_component`) filled and closed.

    The kernels are `SMOOTHING` of the shorter side of `bounds` (left, top, right, bottom),
    whose centre is the centre of `_central_component`.
    """
    left, top, right, bottom = bounds
    size = max(3, round(SMOOTHING * min(right - left, bottom - top)) | 1)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
    found = cv2.morphologyEx(found, cv2.MORPH_OPEN, kernel)
    centre = 0.5 * np.array([left + right, top + bottom])
    subject = _filled(_central_component(found, centre, np.array([right - left, bottom - top])))
    return cv2.morphologyEx(subject, cv2.MORPH_CLOSE, kernel)


def _central_component(mask: np.ndarray, centre: np.ndarray, extent: np.ndarray) -> np.ndarray:
    """The main region of `mask` (h, w): uint8 (h, w), 1 inside.

    The 8-connected component of the largest area x exp(-r^2) wins, r being the
    distance of its centroid from `centre` (x, y) in units of half the `extent`
    (width, height): one centred on a corner of the rectangle must be 7.4 times
    larger than a centred one.  Components of at least `MERGE_AREA` of its area
    closer to it than `MERGE_GAP` of the extent's diagonal join it (a straight
    bridge across each gap): a subject cut in two by a thin strip of background-coloured
    pixels, as a portrait by a dark collar, stays one subject.
    """
    count, labels, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
    if count <= 1:
        return np.zeros(mask.shape, np.uint8)
    area = stats[1:, cv2.CC_STAT_AREA]
    offset = (centroids[1:] + 0.5 - centre) / (0.5 * extent)
    best = 1 + int(np.argmax(area * np.exp(-np.sum(offset**2, axis=1))))
    gap = MERGE_GAP * float(np.hypot(*extent))
    distance = cv2.distanceTransform((labels != best).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    nearest = minimum(distance, labels, index=np.arange(1, count))
    joined = np.flatnonzero((nearest <= gap) & (area >= MERGE_AREA * area[best - 1])) + 1
    region = np.isin(labels, joined).astype(np.uint8)
    best_points = np.argwhere(labels == best)[:, ::-1]  # (x, y)
    for part in joined[joined != best]:
        points = np.argwhere(labels == part)[:, ::-1]
        start = points[np.argmin(distance[points[:, 1], points[:, 0]])]
        end = best_points[np.argmin(np.sum((best_points - start) ** 2, axis=1))]
        # A bridge half as wide as it is long: the B-spline smooths it into a waist.
        thickness = max(3, round(0.5 * nearest[part - 1]))
        cv2.line(region, tuple(int(v) for v in start), tuple(int(v) for v in end), 1, thickness)
    return region


def bays_filled(subject: np.ndarray, bounds: tuple[int, int, int, int]) -> np.ndarray:
    """`subject` (h, w) uint8 with its holes and narrow-mouthed bays filled: uint8 (h, w), 1 inside.

    A closing by a disk of radius r = `BAY_MOUTH` sqrt(area) whose dilation has its holes
    filled before the erosion: the dilation seals every bay whose mouth is narrower
    than 2 r, the filling fills the sealed bay however deep it is, the erosion gives
    back the outline elsewhere (an open concave corner is only rounded, within r).
    Distance transforms stand for the dilation and the erosion, whose cost would grow
    with r.  Nothing outside `bounds` (left, top, right, bottom) is added.
    """
    left, top, right, bottom = bounds
    radius = BAY_MOUTH * np.sqrt(float(subject.sum()))
    pad = int(np.ceil(radius)) + 1
    padded = cv2.copyMakeBorder(subject, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=0)
    outside = cv2.distanceTransform(1 - padded, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    grown = _filled((outside <= radius).astype(np.uint8))
    inside = cv2.distanceTransform(grown, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    closed = (inside > radius)[pad:-pad, pad:-pad] | (subject > 0)
    allowed = np.zeros(subject.shape, bool)
    allowed[top:bottom, left:right] = True
    return _filled((closed & allowed).astype(np.uint8))


def _resized(mask: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """0/1 `mask` (h, w) resized to `shape` (H, W) by bilinear interpolation: uint8 (H, W)."""
    if mask.shape == tuple(shape):
        return mask.astype(np.uint8)
    resized = cv2.resize(mask.astype(np.float32), shape[::-1], interpolation=cv2.INTER_LINEAR)
    return (resized >= 0.5).astype(np.uint8)


def _filled(mask: np.ndarray) -> np.ndarray:
    """`mask` (h, w) uint8 with every hole filled: the inside of its outer contours."""
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    filled = np.zeros_like(mask)
    cv2.drawContours(filled, contours, -1, 1, thickness=cv2.FILLED)
    return filled


def grown(mask: np.ndarray, fraction: float) -> np.ndarray:
    """`mask` (H, W) bool grown by `fraction` of its bounding box's diagonal (at least one pixel)."""
    rows, columns = np.nonzero(mask)
    radius = max(1.0, fraction * np.hypot(np.ptp(rows) + 1, np.ptp(columns) + 1))
    # The Euclidean distance transform costs the same for any radius, a dilation grows with it.
    outside = cv2.distanceTransform((~mask).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    return outside <= radius


def _largest_component(mask: np.ndarray, *, avoid_border: bool = False) -> tuple[bool, int, np.ndarray]:
    """(touches the border, area, mask) of the largest 8-connected component.

    With `avoid_border`, components touching the border count only if no other exists.
    """
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    if count <= 1:
        return True, 0, np.zeros(mask.shape, dtype=bool)
    height, width = mask.shape
    left, top = stats[1:, cv2.CC_STAT_LEFT], stats[1:, cv2.CC_STAT_TOP]
    right, bottom = left + stats[1:, cv2.CC_STAT_WIDTH], top + stats[1:, cv2.CC_STAT_HEIGHT]
    touches = (left == 0) | (top == 0) | (right == width) | (bottom == height)
    area = stats[1:, cv2.CC_STAT_AREA]
    order = np.lexsort((-area, touches)) if avoid_border else np.argsort(-area)
    best = int(order[0])
    return bool(touches[best]), int(area[best]), labels == best + 1
