"""Pins for ``warp`` and sessions: a PINS.json file or a session's ``pins``, solved into the target
cage by `core.pin_deform`, and ``--report``'s lines about them.

PINS.json is ``{"pins": [[x, y], ...], "moved": [[x, y], ...]}`` in image pixels; a session holds
``"pins": [{"at": [x, y], "to": [x, y]}, ...]``, ``"max_distortion"`` (a number >= 1, or absent
for no bound) and ``"fixed"`` (indices of control points moved by hand, held where the session's
target has them).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace

import numpy as np

from app.io.files import InputError, finite_number, read_json
from app.io.session import Session

#: The two lists of a PINS.json file: the pins, and where each is moved.
PINS_FILE_KEYS = ("pins", "moved")


@dataclass(frozen=True)
class PinRequest:
    """Pins to solve: pins (m, 2) and where they go (m, 2), the bound K (None: none) and the
    control points held (index to position (2,)), with how messages name where they came from."""

    pins: np.ndarray
    moved: np.ndarray
    max_distortion: float | None
    source: str
    fixed: dict = field(default_factory=dict)


def pin_request(args, session: Session | None) -> PinRequest | None:
    """``warp``'s pins: ``--pins`` (with ``--max-distortion``), or the session's (its bound, or
    ``--max-distortion`` instead); None without pins."""
    bound = None if args.max_distortion is None else checked_bound(args.max_distortion, "--max-distortion")
    if args.pins is not None:
        if args.target is not None:
            raise InputError("give --target or --pins, not both: the pins' solve makes the target")
        return read_pins(args.pins, bound)
    request = None if session is None else session_pins(session, args.session)
    if request is None and args.max_distortion is not None:
        raise InputError(
            "--max-distortion bounds the pins' warp: give --pins PINS.json (or a session with pins)"
        )
    if request is not None and args.max_distortion is not None:
        request = replace(request, max_distortion=bound)
    return request


def pinned_inputs(inputs, curve, request: PinRequest | None):
    """`app.warp.job.WarpInputs` with the pins' target (and their solve, for ``--report``)."""
    if request is None:
        return inputs
    result = pinned_target(curve, request, inputs.kernel)
    return replace(
        inputs, target=result.target, target_source=f"{request.source} (the pins' target)", pinned=result
    )


def read_pins(path: str | os.PathLike, max_distortion: float | None) -> PinRequest:
    """The pins of a PINS.json file, with the command line's bound."""
    value = read_json(path)
    where = str(path)
    if not isinstance(value, dict) or not all(key in value for key in PINS_FILE_KEYS):
        raise InputError(f'{where}: expected an object with "pins" and "moved", lists of [x, y] pairs')
    pins, moved = (_points(value[key], f'{where}: "{key}"') for key in PINS_FILE_KEYS)
    if len(pins) != len(moved):
        raise InputError(
            f'{where}: {len(pins)} "pins" but {len(moved)} "moved" points; give one for each pin'
        )
    return PinRequest(pins, moved, max_distortion, where)


def session_pins(session: Session, path: str | os.PathLike) -> PinRequest | None:
    """The pins a session holds (None if it holds none); the session's model has checked ``pins``
    and ``max_distortion`` (`app.io.session`), ``fixed`` is checked here."""
    if not session.pins:
        return None
    pins = np.array([pin.at for pin in session.pins], dtype=np.float64)
    moved = np.array([pin.to for pin in session.pins], dtype=np.float64)
    fixed = session.extra.get("fixed", [])
    if not isinstance(fixed, list) or not all(
        isinstance(i, int) and not isinstance(i, bool) and 0 <= i < len(session.target) for i in fixed
    ):
        raise InputError(
            f"{path}: fixed: must be a list of control point indices from 0 to {len(session.target) - 1}"
        )
    return PinRequest(
        pins, moved, session.max_distortion, f"{path}: pins", {i: session.target[i] for i in fixed}
    )


def checked_bound(value, where: str) -> float | None:
    """A bound K >= 1 (None or absent: no bound; a JSON null too)."""
    if value is None:
        return None
    number = finite_number(value) if not isinstance(value, str) else None
    if number is None and isinstance(value, float) and math.isinf(value) and value > 0:
        return None
    if number is None or number < 1.0:
        raise InputError(
            f"{where}: must be a number >= 1 (sigma1/sigma2 is never below 1), got {value!r:.60}"
        )
    return number


def pinned_target(curve, request: PinRequest, kernel: str):
    """`core.pin_deform`'s result for the request on the source cage `curve`; its refusals as
    `InputError` naming the request's source."""
    from core import pin_deform

    try:
        return pin_deform(
            curve, request.pins, request.moved, max_distortion=request.max_distortion,
            fixed=request.fixed or None, kernel=kernel,
        )  # fmt: skip
    except ValueError as error:
        raise InputError(f"{request.source}: {error}") from None


def pin_report(result) -> list[str]:
    """``--report``'s lines: each pin's error, the ones that miss, and the certified bound."""
    lines = [
        f"pin {j}: lands {error:.3g} px from where it was moved" for j, error in enumerate(result.pin_error)
    ]
    if result.missed.size:
        worst = ", ".join(f"{j} by {result.pin_error[j]:.3g} px" for j in result.missed)
        lines.append(f"pins that miss: {worst}")
    asked = (
        "no bound asked"
        if result.max_distortion is None
        else f"asked sigma1/sigma2 <= {result.max_distortion:g}"
    )
    proven = result.proven_distortion
    if math.isfinite(proven):
        lines.append(f"distortion: {asked}; proven sigma1/sigma2 <= {proven:.4g} and det J > 0 (fold-free)")
    else:
        lines.append(f"distortion: {asked}; not proven: {result.certificate}")
    return lines


def _points(value, where: str) -> np.ndarray:
    """A list of [x, y] number pairs as an ndarray (m, 2), at least one."""
    if not isinstance(value, list) or not value:
        raise InputError(f"{where}: must be a non-empty list of [x, y] pairs")
    for index, point in enumerate(value):
        if not (
            isinstance(point, list) and len(point) == 2 and all(finite_number(c) is not None for c in point)
        ):
            raise InputError(f"{where}[{index}]: must be a pair of finite numbers [x, y], got {point!r:.60}")
    return np.array(value, dtype=np.float64)
