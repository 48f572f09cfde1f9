"""Pictures, meshes and masks made for the renderer's tests."""

from __future__ import annotations

import cv2
import numpy as np
from scipy.spatial import Delaunay


def smooth_image(width=320, height=240, seed=0):
    """Opaque RGBA test picture: smooth waves, a ramp and one hard-edged square, (H, W, 4) uint8."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    phase = rng.uniform(0, 2 * np.pi, 3)
    image = np.empty((height, width, 4), dtype=np.uint8)
    image[..., 0] = 127.5 + 127 * np.sin(x / 9 + phase[0]) * np.cos(y / 13 + phase[1])
    image[..., 1] = 127.5 + 127 * np.sin((x + 2 * y) / 17 + phase[2])
    image[..., 2] = 255 * x / width
    image[..., 3] = 255
    image[height // 3 : height // 2, width // 3 : width // 2, :3] = (250, 30, 60)
    return image


def ellipse_mesh(center, axes, spacing, seed=1):
    """Delaunay mesh of an ellipse polygon with jittered interior points.

    Returns vertices (V, 2), triangles (T, 3) and the boundary polygon (B, 2) in order.
    """
    rng = np.random.default_rng(seed)
    a, b = axes
    count = int(np.ceil(np.pi * (a + b) / spacing))
    angles = 2 * np.pi * np.arange(count) / count
    boundary = np.stack([center[0] + a * np.cos(angles), center[1] + b * np.sin(angles)], axis=1)
    y, x = np.mgrid[-b:b:spacing, -a:a:spacing]
    interior = np.stack([x.ravel(), y.ravel()], axis=1) + rng.uniform(-0.3, 0.3, (x.size, 2)) * spacing
    inside = (interior[:, 0] / (a - spacing / 2)) ** 2 + (interior[:, 1] / (b - spacing / 2)) ** 2 < 1
    vertices = np.vstack([boundary, interior[inside] + center])
    return vertices, Delaunay(vertices).simplices, boundary


def polygon_mask(polygon, shape, inset):
    """Pixels whose centres are inside `polygon` by more than `inset` pixels (negative: outside by -inset)."""
    mask = np.zeros(shape, dtype=np.uint8)
    cv2.fillPoly(mask, [np.round((polygon - 0.5) * 256).astype(np.int32)], 1, shift=8)
    radius = int(np.ceil(abs(inset)))
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))
    if inset >= 0:
        return cv2.erode(mask, kernel).astype(bool)
    return ~cv2.dilate(mask, kernel).astype(bool)
