"""The figure of ``python -m app quality --output FIG.png``: the hardest deformations of the suite,
one column per kernel, drawn with OpenCV (no OpenGL needed).

Each panel shows the deformed mesh (grey), its folded triangles (red), the target
curve (blue) and the interior vertices mapped outside it (orange), as in the
paper's Fig. 11.  The rows are the `ROWS` deformations with the largest folded area
averaged over the kernels.
"""

from __future__ import annotations

import cv2
import numpy as np

from core import deform

PANEL = 260
LABEL_HEIGHT = 40
ROW_LABEL_WIDTH = 150
ROWS = 3
FONT = cv2.FONT_HERSHEY_SIMPLEX
# Colours (B, G, R).
MESH = (205, 205, 205)
FOLDED = (40, 40, 220)
TARGET = (200, 90, 20)
OUTSIDE = (0, 140, 255)


def figure(domains, study) -> np.ndarray:
    """Draw the study's hardest deformations for every measured kernel.

    Parameters
    ----------
    domains : list of app.studies.quality_suite.Domain
        The suite that `study` measured.
    study : app.studies.quality.StudyResult
        Measured with ``keep=True``.

    Returns
    -------
    ndarray of shape (H, W, 4), uint8
        Opaque RGBA on white.
    """
    import core
    from core import distortion

    kernels = [result for result in study.kernels if result.skipped is None]
    folded = np.array([result.folded for result in kernels])  # (kernels, deformations)
    hardest = np.argsort(-folded.mean(axis=0), kind="stable")[:ROWS]
    targets = {(d.name, f.label): f.target for d in domains for f in d.deformations}
    height = LABEL_HEIGHT + len(hardest) * PANEL
    canvas = np.full((height, ROW_LABEL_WIDTH + len(kernels) * PANEL, 3), 255, dtype=np.uint8)
    _text(canvas, "red: folded", (8, 14), 0.38, FOLDED)
    _text(canvas, "orange: outside", (8, 26), 0.38, OUTSIDE)
    _text(canvas, "blue: target curve", (8, 38), 0.38, TARGET)
    for column, result in enumerate(kernels):
        left = ROW_LABEL_WIDTH + column * PANEL
        summary = result.summary()
        _text(canvas, result.choice.label, (left + 6, 16), 0.45)
        _text(
            canvas,
            f"folded {100 * summary['folded']:.2f}%  out {100 * summary['outside']:.2f}%",
            (left + 6, 33),
            0.38,
        )
    for row, index in enumerate(hardest):
        domain, label = study.deformations[index]
        top = LABEL_HEIGHT + row * PANEL
        _text(canvas, domain, (8, top + PANEL // 2 - 8), 0.45)
        _text(canvas, label, (8, top + PANEL // 2 + 12), 0.45)
        mesh = study.meshes[domain]
        target = targets[domain, label]
        outline = core.ClosedBSpline(target)(np.linspace(0.0, len(target), 64 * len(target), endpoint=False))
        deformed = {
            r.choice.label: study.positions.get((domain, r.choice.label, label))
            if r.choice.fold_free
            else deform(study.bases[domain, r.choice.label], target)
            for r in kernels
        }
        everything = np.concatenate([outline, *deformed.values()])
        low, high = everything.min(axis=0), everything.max(axis=0)
        scale = (PANEL - 16) / max(float((high - low).max()), 1e-300)
        for column, result in enumerate(kernels):
            left = ROW_LABEL_WIDTH + column * PANEL

            origin = np.array([left + 8, top + 8])

            def pixels(points, origin=origin, low=low, scale=scale):
                # 1/16 pixel fixed point (cv2 shift=4); y up in the suite is y down on screen,
                # a mirror image that shows folds and spill-out equally well.
                return np.round(16 * ((points - low) * scale + origin)).astype(np.int32)

            positions = deformed[result.choice.label]
            sigma = distortion.signed_singular_values(
                distortion.triangle_jacobians(mesh.vertices, positions, mesh.triangles)
            )
            corners = pixels(positions)[mesh.triangles]
            cv2.fillPoly(canvas, list(corners), MESH, cv2.LINE_AA, shift=4)
            interior = mesh.interior
            outside = interior[~core.ClosedBSpline(target).contains(positions[interior])]
            for point in pixels(positions[outside]):
                cv2.circle(canvas, tuple(int(v) for v in point), 16, OUTSIDE, -1, cv2.LINE_AA, shift=4)
            # Folds on top: they matter most.
            is_folded = sigma[:, 0] * sigma[:, 1] <= distortion.COLLAPSE
            if is_folded.any():
                cv2.fillPoly(canvas, list(corners[is_folded]), FOLDED, cv2.LINE_AA, shift=4)
            cv2.polylines(canvas, [pixels(outline)], True, TARGET, 1, cv2.LINE_AA, shift=4)
            cv2.rectangle(canvas, (left, top), (left + PANEL - 1, top + PANEL - 1), (230, 230, 230), 1)
    rgb = canvas[..., ::-1]
    return np.dstack([rgb, np.full(rgb.shape[:2], 255, dtype=np.uint8)])


def _text(canvas: np.ndarray, text: str, origin: tuple[int, int], size: float, colour=(0, 0, 0)) -> None:
    cv2.putText(canvas, text, origin, FONT, size, colour, 1, cv2.LINE_AA)
