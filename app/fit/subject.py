"""Fit a cage (closed uniform quadratic B-spline, Sec. 4.1) around the main subject of an image.

The subject (`subject_mask`) is, in this order of trust:

- the alpha channel, when the image has one that is not all opaque;
- a silhouette on a plain background, when the grey levels are two-toned (Otsu's
  threshold explains at least `TWO_TONE` of their variance): the largest object of
  that threshold, in the polarity in which it does not touch the border;
- otherwise a photograph: GrabCut (Rother, Kolmogorov and Blake 2004) on a copy of
  about `SEGMENT_PIXELS` pixels.  Outside the rectangle is background; inside it
  the probable subject is seeded by the geodesic boundary saliency
  (`boundary_saliency`) and by the colours that the border does not explain
  (`border_contrast`); when the depth of field is shallow (`in_focus`), only what
  is in focus, and the subject may then run into the border; then the subject found
  without the focus prior joins it where they overlap.
  Of what GrabCut keeps, the largest and most central region is taken, its holes
  filled and its outline smoothed; then the band along its outline is decided
  anew on a finer copy (`refined_subject`), from the colours of the subject's core
  and of the background next to it; the subject grows where its own colours nearby
  explain a pixel better than the background's nearby (`locally_grown`: a rocket's
  grey nose, which GrabCut gives to the sky because grey towers elsewhere share its
  colours); and holes and bays with a narrow mouth (a dark collar between a face and
  a suit) are filled.  The cage goes `SUBJECT_MARGIN` outside the result, because
  a segmentation is uncertain by a few pixels and a cage that cuts into the subject
  tears it when deformed, while a thin band of background inside
  the cage just moves along.

A photograph's subject is uncertain when it is tiny or when colour hardly tells it
from the background around it (`colour_separation`): `fit_cage` then warns.  With a
rectangle from the user there is always a cage, inside it: the rectangle itself
when nothing stands out there.

Alpha channels and plain silhouettes are exact to the pixel and get no margin.  The
outer contour of the subject is parameterised by arc length and the n control
points solve the linear least squares problem ``B(t) P = contour`` with the folded
basis of `core.curves.bspline`; then a few rounds move every parameter to its foot point
on the current curve and minimise the distances to the tangent lines there, so
the result fits the distance to the curve, not to fixed parameters.

Coordinates are image pixels, x right, y down, origin at the image's top-left
corner; pixel (column i, row j) covers [i, i+1] x [j, j+1].  A rectangle is
(x, y, width, height) in the same pixels.
"""

from __future__ import annotations

import warnings

import cv2
import numpy as np
from scipy.ndimage import gaussian_filter1d, minimum

from app.fit.colours import (
    DEFAULT_INSET,
    MIN_SAMPLES,
    border_contrast,
    boundary_saliency,
    frame_mask,
    in_focus,
)
from app.fit.curve import fit_closed_bspline, rectangle_cage, snap_corners
from app.fit.doubt import colour_separation
from app.fit.growth import locally_grown, within_bounds
from app.io.images.writing import eight_bit
from core import DEFAULT_SAMPLES_PER_SEGMENT, MAX_BOUNDARY_SAMPLES, ClosedBSpline, positive_int

#: Most control points of a fitted cage: what the kernels sample at their default density.
MAX_POINTS = MAX_BOUNDARY_SAMPLES // DEFAULT_SAMPLES_PER_SEGMENT
#: Larger images are fitted on a copy of at most this many pixels (1024 x 1024), shrunk by a
#: whole factor: the segmentation's thresholds and windows are in pixels, so a photograph
#: and its copies at other resolutions must be seen at about the same one (issue 36: a
#: 4000 x 3000 photograph gets the cage of its 1000 x 750 copy); the cage's accuracy is a
#: fraction of a span.
FIT_PIXELS = 1 << 20
#: Share of the grey levels' variance that Otsu's two classes must explain for an
#: opaque image to count as a silhouette on a plain background (antialiased
#: silhouettes: above 0.97; photographs of scikit-image's data: 0.57 to 0.86).
TWO_TONE = 0.92
#: GrabCut runs on a copy of about this many pixels (256 x 256): its cost grows with
#: the pixels, and a cage of a few dozen control points needs no finer outline.
SEGMENT_PIXELS = 1 << 15
#: GrabCut's rounds of colour models and graph cut.
GRABCUT_ITERATIONS = 4
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
#: A subject of less than `SMALL_SUBJECT` of the picture (or rectangle), or whose colours
#: and those of the background around it tell them apart for less than `SEPARATION` of
#: their pixels (`colour_separation`), is uncertain: `fit_cage` warns
#: (`SubjectUncertainWarning`).  Measured on scikit-image's photographs: 0.80 to 0.995
#: where the cage holds the subject (cameraman 0.80, astronaut and chelsea 0.85), 0.73
#: and 0.66 on the motorcycle and the coins, whose cages miss much of them, 0.66 and 0.87
#: on the Hubble deep field and the moon, which have no single subject (the moon's is
#: 0.3 % of the picture).
SMALL_SUBJECT = 0.01
SEPARATION = 0.78
#: Other parts of GrabCut's result join the main one when at least this share of its
#: area and closer than `MERGE_GAP` of the rectangle's diagonal (`_central_component`).
MERGE_AREA = 0.1
MERGE_GAP = 0.15
#: Opening and closing of GrabCut's mask, as a fraction of the rectangle's shorter side.
SMOOTHING = 0.02
#: The cage of a segmented subject goes around it grown by this fraction of the
#: diagonal of its bounding box.
SUBJECT_MARGIN = 0.015
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
#: Holes and bays of the subject whose mouth is narrower than twice this fraction of the
#: square root of its area are filled (`_bays_filled`): a portrait's dark collar ring,
#: left out by its colour, is part of the subject; an L's open corner stays open.
BAY_MOUTH = 0.15


class CageFitWarning(UserWarning):
    """The fit had to change the request (fewer points or smoothing) to stay simple."""


class SubjectUncertainWarning(UserWarning):
    """The subject of a photograph is uncertain: the cage may hold the wrong thing."""


def fit_cage(
    image: np.ndarray,
    points: int = 16,
    rect=None,
    max_pixels: int = FIT_PIXELS,
) -> np.ndarray:
    """Control points of a closed quadratic B-spline around the image's main subject.

    Parameters
    ----------
    image : ndarray of shape (H, W, 4) or (H, W, 3), uint8 or uint16
        RGBA or RGB, row 0 at the top.
    points : int
        n >= 3, the number of control points.
    rect : sequence of 4 numbers (x, y, width, height), optional
        Where the subject is, in image pixels; it must lie inside the image.  Only
        what is inside is considered.  Default: the whole image (for a photograph,
        all but a frame of `DEFAULT_INSET` of each side).
    max_pixels : int
        An image of more pixels is fitted on a copy shrunk by a whole factor to at most this
        many (`working_copy`), and the cage mapped back to the image's pixels.

    Returns
    -------
    ndarray of shape (m, 2), float64
        Control points in image pixels; m == points unless that curve crossed
        itself, in which case the contour is smoothed and then m is lowered until
        the curve is simple, with a `CageFitWarning` saying so.  Pairs closer
        than a pixel (of the fitted copy) are merged into sharp corners
        (`snap_corners`).  The curve follows the outline of `subject_mask`, grown
        by `SUBJECT_MARGIN` when the subject was segmented from a photograph.
        With `rect` the curve always lies inside it: its control points are held
        there, and when nothing stands out in it (a texture), or what does has
        too short an outline, the cage is the rectangle (`rectangle_cage`).

    Warns
    -----
    SubjectUncertainWarning
        When the subject of a photograph is uncertain (`_warn_if_uncertain`), or
        the cage is the rectangle because nothing stood out in it.
    CageFitWarning
        When the request was changed to keep the curve simple.

    Raises
    ------
    ValueError
        If the image or the rectangle is invalid, or, without `rect`, the image
        holds no object or the object is too small for `points`.
    """
    points = positive_int(points, "points", minimum=3)
    if points > MAX_POINTS:
        raise ValueError(
            f"points={points:,} is more than the {MAX_POINTS:,} control points the kernels sample at "
            f"{DEFAULT_SAMPLES_PER_SEGMENT} per span; use 3 <= points <= {MAX_POINTS:,}"
        )
    image = _checked_image(image)
    rect = checked_rect(rect, image.shape[1], image.shape[0])
    image, scale = working_copy(image, positive_int(max_pixels, "max_pixels"))
    region = None if rect is None else rect / np.tile(scale, 2)
    mask, exact = _subject(image, region)
    if mask is None:
        warnings.warn(
            "the subject is uncertain: nothing stands out inside the rectangle, so the cage is the rectangle",
            SubjectUncertainWarning,
            stacklevel=2,
        )
        return rectangle_cage(rect, points)
    if not exact:
        _warn_if_uncertain(image, mask, region)
        mask = _grown(mask, SUBJECT_MARGIN)
    contour = mask_outline(mask)
    if len(contour) < 3 * points:
        if region is not None:
            warnings.warn(
                f"the subject's outline in the rectangle has only {len(contour)} pixels, too few for "
                f"{points} control points: the cage is the rectangle",
                CageFitWarning,
                stacklevel=2,
            )
            return rectangle_cage(rect, points)
        raise ValueError(
            f"the subject's outline has only {len(contour)} pixels, too few for {points} control "
            "points; use fewer points or a larger image"
        )
    control_points = _simple_curve(contour, points, region, scale)
    if control_points is not None:
        if rect is None:
            return control_points * scale
        return np.clip(control_points * scale, rect[:2], rect[:2] + rect[2:])
    if region is not None:
        warnings.warn(
            "no simple curve fits the subject: the cage is the rectangle", CageFitWarning, stacklevel=2
        )
        return rectangle_cage(rect, points)
    raise ValueError("could not fit a simple closed curve to the subject")


def _simple_curve(contour: np.ndarray, points: int, region, scale: np.ndarray) -> np.ndarray | None:
    """Control points (m, 2) of a simple curve fitted to `contour` (K, 2), in the fitted copy's pixels.

    m is `points` unless that curve crosses itself: then the contour is smoothed over a
    growing fraction of a span, and m lowered, until it does not (a `CageFitWarning` says
    so).  With `region` (x, y, w, h) the control points are held inside it.  None if no
    simple curve of 3 or more points was found.
    """
    length = _perimeter(contour)
    for count in range(points, 2, -1):
        for smoothing in (0.0, 0.25, 0.5, 1.0):
            # Smoothing over a fraction of one span irons out wiggles that make the
            # fit loop, without changing the shape at the scale of the spans.
            sigma = smoothing * len(contour) / count
            data = gaussian_filter1d(contour, sigma, axis=0, mode="wrap") if sigma else contour
            control_points = snap_corners(fit_closed_bspline(data, count))
            if region is not None:
                # Each span lies in the convex hull of its three control points: with them
                # in the rectangle, so is the whole curve.
                control_points = np.clip(control_points, region[:2], region[:2] + region[2:])
            try:
                ClosedBSpline(control_points)
            except ValueError:
                continue
            if (count, smoothing) != (points, 0.0):
                remedy = [f"used {count} points"] if count != points else []
                if sigma:
                    pixels = sigma * length / len(contour) * float(np.sqrt(np.prod(scale)))
                    remedy.append(f"smoothed the outline over {pixels:.1f} px")
                warnings.warn(
                    f"the fitted curve with {points} control points crossed itself; {' and '.join(remedy)}",
                    CageFitWarning,
                    stacklevel=3,
                )
            return control_points
    return None


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
    image = _checked_image(image)
    mask = _subject(image, checked_rect(rect, image.shape[1], image.shape[0]))[0]
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


def working_copy(image: np.ndarray, max_pixels: int) -> tuple[np.ndarray, np.ndarray]:
    """`image` (H, W, C) shrunk by area averaging by the smallest whole factor k that leaves at most
    `max_pixels` pixels: about W / k x H / k, the image itself if it has no more.

    A whole factor makes a photograph and its copy shrunk by a factor of it the same picture
    here (area averaging over k x k blocks).  Returns the copy and the scale (W / w, H / h), as
    `downscaled`.
    """
    height, width = image.shape[:2]
    if height * width <= max_pixels:
        return image, np.ones(2)
    factor = int(np.ceil(np.sqrt(height * width / max_pixels)))
    while round(width / factor) * round(height / factor) > max_pixels:
        factor += 1
    size = (max(1, round(width / factor)), max(1, round(height / factor)))
    small = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
    return small, np.array([width / size[0], height / size[1]])


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
    image = _checked_image(image)
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
    (`refined_subject`, nothing outside the rectangle), grown where only the background
    next to it tells it apart (`locally_grown`), its holes and narrow-mouthed bays
    filled (`_bays_filled`), and scaled back to (H, W), each time by bilinear
    interpolation of the 0/1 mask (`_refined_hypothesis`).  With a shallow depth of
    field a second hypothesis is made without the focus prior, in the salient
    rectangle; when it overlaps the first, the subject is their union: on
    scikit-image's cameraman the first holds the head, camera and tripod, the second
    the head and the dark coat that runs out of focus into the border.
    """
    height, width = image.shape[:2]
    small, scale = downscaled(np.ascontiguousarray(image[..., :3]), SEGMENT_PIXELS)
    saliency = np.round(255 * boundary_saliency(small)).astype(np.uint8)
    otsu, _ = cv2.threshold(saliency, 0, 1, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    if rect is None:
        bounds = _salient_bounds(saliency > RECT_LEVEL * otsu)
    else:
        bounds = _pixel_bounds(np.asarray(rect) / np.tile(scale, 2), small.shape[:2])
    bgr = np.ascontiguousarray(small[..., ::-1])
    probable = (saliency > SEED_LEVEL * otsu) | border_contrast(bgr)
    fine, fine_scale = downscaled(np.ascontiguousarray(image[..., :3]), REFINE_PIXELS)
    limits = (0, 0, fine.shape[1], fine.shape[0])
    if rect is not None:
        limits = _pixel_bounds(np.asarray(rect) / np.tile(fine_scale, 2), fine.shape[:2])
    fine_bgr = np.ascontiguousarray(fine[..., ::-1])
    sharp = in_focus(fine, small)
    subject = _refined_hypothesis(bgr, saliency, probable, bounds, sharp, rect is None, fine_bgr, limits)
    if sharp is not None:
        # A second hypothesis without the focus prior: a subject partly out of focus (a dark
        # coat in the foreground) may be found there; when the two overlap they are parts
        # of one subject.
        other = _refined_hypothesis(bgr, saliency, probable, bounds, None, False, fine_bgr, limits)
        if (subject & other).any():
            subject |= other
    return _resized(subject, (height, width)) > 0


def _refined_hypothesis(
    bgr: np.ndarray,
    saliency: np.ndarray,
    probable: np.ndarray,
    bounds: tuple[int, int, int, int],
    sharp: np.ndarray | None,
    whole: bool,
    fine_bgr: np.ndarray,
    limits: tuple[int, int, int, int],
) -> np.ndarray:
    """One of `photo_subject`'s hypotheses: uint8 (h', w') on the fine copy `fine_bgr`, 1 on the subject.

    GrabCut of `bgr` (h, w, 3) inside `bounds` from the seeds `probable` (h, w) bool, restricted
    to `sharp` (h, w) bool when given; with `whole`, the whole picture is considered, its
    frame background only where not probable.  A result below `MIN_SUBJECT` of the
    rectangle is retried from the rectangle alone.  The result is refined on the fine copy
    within `limits` (left, top, right, bottom), grown there (`locally_grown`) and its
    narrow-mouthed bays filled.
    """
    left, top, right, bottom = bounds
    seeds = np.full(bgr.shape[:2], cv2.GC_BGD, np.uint8)
    if sharp is not None:
        # A shallow depth of field: what is out of focus is background.
        probable = probable & sharp
    if sharp is not None and whole:
        # A subject in focus may run into the border (a close-up's ears): the frame is
        # background only where it is not probable subject.
        bounds = left, top, right, bottom = 0, 0, bgr.shape[1], bgr.shape[0]
        seeds[~frame_mask(bgr.shape[:2])] = cv2.GC_PR_BGD
    else:
        seeds[top:bottom, left:right] = cv2.GC_PR_BGD
    inside = (slice(top, bottom), slice(left, right))
    seeds[inside] = np.where(probable[inside], cv2.GC_PR_FGD, seeds[inside])
    subject = _grabcut_region(bgr, seeds, bounds)
    if subject.sum() < MIN_SUBJECT * (right - left) * (bottom - top):
        seeds = np.where(seeds == cv2.GC_BGD, seeds, cv2.GC_PR_FGD).astype(np.uint8)
        larger = _grabcut_region(bgr, seeds, bounds)
        if larger.sum() > subject.sum() and (_stands_out(saliency, larger) or not subject.any()):
            subject = larger
    subject = refined_subject(fine_bgr, _resized(subject, fine_bgr.shape[:2]), limits)
    return _bays_filled(locally_grown(fine_bgr, subject, limits), limits)


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


def _warn_if_uncertain(image: np.ndarray, subject: np.ndarray, rect: np.ndarray | None) -> None:
    """`SubjectUncertainWarning` when the photograph's `subject` (H, W) bool is small (`SMALL_SUBJECT`)
    or hardly told apart from the background by colour (`SEPARATION`).

    The colours are compared on a copy of about `SEGMENT_PIXELS` pixels, the background
    around the subject being its `_ring`.
    """
    height, width = image.shape[:2]
    where = "the picture" if rect is None else "the rectangle"
    share = subject.sum() / (height * width if rect is None else rect[2] * rect[3])
    reasons = []
    if share < SMALL_SUBJECT:
        reasons.append(f"what was found covers only {100 * share:.1f} % of {where}")
    small, _ = downscaled(np.ascontiguousarray(image[..., :3]), SEGMENT_PIXELS)
    inside = _resized(subject, small.shape[:2])
    separation = colour_separation(np.ascontiguousarray(small[..., ::-1]), inside > 0, _ring(inside))
    if separation < SEPARATION:
        reasons.append(
            f"colour tells it from the background around it for only {100 * separation:.0f} % of pixels"
        )
    if reasons:
        advice = "a tighter rectangle" if rect is not None else "a rectangle around the subject (fit --rect)"
        warnings.warn(
            f"the subject is uncertain: {' and '.join(reasons)}; check the cage, or give {advice}",
            SubjectUncertainWarning,
            stacklevel=3,
        )


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
    allowed = within_bounds(subject.shape, bounds)
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


def mask_outline(mask: np.ndarray) -> np.ndarray:
    """Outer outline of the largest region of `mask` (H, W), ndarray of shape (K, 2), image pixels.

    The points are the centres of the boundary pixels moved half a pixel outwards,
    which puts them on the edge between object and background.
    """
    contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    contour = max(contours, key=cv2.contourArea).reshape(-1, 2).astype(np.float64) + 0.5
    tangent = np.roll(contour, -2, axis=0) - np.roll(contour, 2, axis=0)
    tangent /= np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-12)
    area = 0.5 * np.sum(
        contour[:, 0] * np.roll(contour[:, 1], -1) - np.roll(contour[:, 0], -1) * contour[:, 1]
    )
    outward = np.sign(area) * np.stack([tangent[:, 1], -tangent[:, 0]], axis=1)
    return contour + 0.5 * outward


def _subject(image: np.ndarray, rect: np.ndarray | None) -> tuple[np.ndarray | None, bool]:
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


def _checked_image(image: np.ndarray) -> np.ndarray:
    """`image` as uint8 (16-bit samples rounded to 8 bits), or ValueError."""
    image = np.asarray(image)
    if image.dtype == np.uint16 and image.ndim == 3:
        image = eight_bit(image)
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


def _bays_filled(subject: np.ndarray, bounds: tuple[int, int, int, int]) -> np.ndarray:
    """`subject` (h, w) uint8 with its holes and narrow-mouthed bays filled: uint8 (h, w), 1 inside.

    A closing by a disk of radius r = `BAY_MOUTH` sqrt(area) whose dilation has its holes
    filled before the erosion: the dilation seals every bay whose mouth is narrower
    than 2 r, the filling fills the sealed bay however deep it is, the erosion gives
    back the outline elsewhere (an open concave corner is only rounded, within r).
    Distance transforms stand for the dilation and the erosion, whose cost would grow
    with r.  Nothing outside `bounds` (left, top, right, bottom) is added.
    """
    radius = BAY_MOUTH * np.sqrt(float(subject.sum()))
    pad = int(np.ceil(radius)) + 1
    padded = cv2.copyMakeBorder(subject, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=0)
    outside = cv2.distanceTransform(1 - padded, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    grown = _filled((outside <= radius).astype(np.uint8))
    inside = cv2.distanceTransform(grown, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    closed = (inside > radius)[pad:-pad, pad:-pad] | (subject > 0)
    return _filled((closed & within_bounds(subject.shape, bounds)).astype(np.uint8))


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


def _grown(mask: np.ndarray, fraction: float) -> np.ndarray:
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


def _perimeter(contour: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(contour, axis=0, append=contour[:1]), axis=1).sum())
