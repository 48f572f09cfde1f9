"""Session files: one typed, validated model (`Session`), read and written here and nowhere else.

A session file is a JSON object.  Required: ``image`` (a path, relative to the file's folder),
``cage`` and ``target`` (cage objects ``{"control_points": [[x, y], ...]}``, image pixels, x
right, y down, origin top-left), ``kernel`` and ``view`` (``{"scale": s, "offset": [ox, oy]}``).
Optional, each read as its default when absent (older sessions):

- ``kernel_params`` (the kernel's parameters, checked against `core.KERNEL_TABLE` and
  `core.kernel_parameters`), ``parameterization`` (``"natural"`` or ``"arc-length"``) and
  ``mesh`` (``{"max_edge": h}``): what the viewer computed with, so that ``warp --session``
  computes the very basis functions it showed;
- ``fold_free`` (true: the certified fold-free map of ``poisson``), ``pins``
  (``[{"at": [x, y], "to": [x, y]}, ...]``) and ``max_distortion`` (a bound K >= 1);
- ``outside``, ``canvas``, ``fill`` and ``background``: what an export shows around the warp
  (`app.warp.framing`, `app.warp.fill`, a colour as ``--background`` takes it);
- ``keyframes`` (``[{"time": s, "target": {cage}}, ...]``) and ``interpolation``
  (`app.warp.keyframes`): the animation ``animate`` renders;
- ``viewer`` (the viewer's own settings: `ViewerSettings`) and ``history`` (its undo and redo
  steps: `History`).

Other keys are kept: read into `Session.extra` and written back unchanged.  Every check runs
when a `Session` (or one of its parts) is built, so a session in memory is always valid; reading
a file turns a failed check into one `InputError` line naming the file and the key.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from numbers import Real
from pathlib import Path

import numpy as np

from app.io.files import (
    InputError,
    cage_points,
    finite_number,
    json_type,
    kernel_names,
    read_json,
    shown,
    write_json,
)
from app.io.images.colours import parse_colour
from app.render.viewport import View
from app.warp.fill import FILLS, checked_fill
from app.warp.framing import CANVASES, OUTSIDES
from app.warp.keyframes import (
    DEFAULT_INTERPOLATION,
    INTERPOLATIONS,
    Keyframe,
    keyframes_json,
    sorted_keyframes,
)
from core import (
    DEFAULT_KERNEL,
    DEFAULT_PARAMETERIZATION,
    KERNEL_TABLE,
    PARAMETERIZATIONS,
    kernel_parameters,
)

#: The keys every session file has.
REQUIRED_KEYS = ("image", "cage", "target", "kernel", "view")
#: The keys this module reads besides the required ones; any other key is kept in `Session.extra`.
OPTIONAL_KEYS = (
    "kernel_params",
    "parameterization",
    "mesh",
    "fold_free",
    "pins",
    "max_distortion",
    "outside",
    "canvas",
    "fill",
    "background",
    "keyframes",
    "interpolation",
    "viewer",
    "history",
)


def checked_kernel_params(kernel: str, params: dict) -> dict:
    """`params` of `kernel`, checked against `core.KERNEL_TABLE` (the names) and
    `core.kernel_parameters` (the values of the compiled kernels); `ValueError` otherwise."""
    if kernel not in kernel_names():
        raise ValueError(f"unknown kernel {kernel!r}; choose one of {', '.join(kernel_names())}")
    accepted = KERNEL_TABLE[kernel].parameters
    unknown = sorted(set(params) - set(accepted))
    if unknown and not accepted:
        raise ValueError(f"kernel {kernel!r} takes no parameters, but kernel_params has {', '.join(unknown)}")
    if unknown:
        raise ValueError(
            f"unknown kernel parameter(s) {', '.join(unknown)} ({kernel} takes {', '.join(accepted)})"
        )
    for name, value in params.items():
        if not _number_or_word(value):
            raise ValueError(f"kernel_params {name} must be a number or a word, got {shown(value)}")
    if params and KERNEL_TABLE[kernel].compiled:
        try:
            kernel_parameters(kernel, params)
        except ValueError as error:
            raise ValueError(f"kernel_params: {error}") from None
    return dict(params)


def _number_or_word(value) -> bool:
    """Whether `value` is a number (not a boolean) or a word that is no number written as text:
    a file says ``"power": 3``, never ``"power": "3"`` or ``true``, which `core` would take."""
    if isinstance(value, str):
        try:
            float(value)
        except ValueError:
            return True
        return False
    return isinstance(value, Real) and not isinstance(value, bool)


@dataclass(frozen=True)
class KernelChoice:
    """The kernel of a session: its name, parameters and boundary parameterization.

    Attributes
    ----------
    name : str
        A name of `app.io.files.kernel_names`.
    params : dict
        Its keyword parameters (``kernel_params``), names from `core.KERNEL_TABLE`.
    parameterization : str
        One of `core.PARAMETERIZATIONS` (the point kernels' boundary parameter, Fig. 12).
    """

    name: str = DEFAULT_KERNEL
    params: dict = field(default_factory=dict)
    parameterization: str = DEFAULT_PARAMETERIZATION

    def __post_init__(self) -> None:
        object.__setattr__(self, "params", checked_kernel_params(self.name, self.params))
        if self.parameterization not in PARAMETERIZATIONS:
            raise ValueError(
                f'"parameterization" must be one of {", ".join(PARAMETERIZATIONS)}, '
                f"got {self.parameterization!r}"
            )


#: The output choices' keys, in `OutputChoice`'s order: top-level keys of a session, and of its
#: history's steps.
OUTPUT_KEYS = ("outside", "canvas", "fill", "background")


@dataclass(frozen=True)
class OutputChoice:
    """What an export shows around the warp.

    Attributes
    ----------
    outside, canvas : str
        One of `app.warp.framing.OUTSIDES` and of `CANVASES`.
    fill : str
        What fills the source cage's region behind the warp (`app.warp.fill.checked_fill`).
    background : str
        ``"none"`` (transparent) or a colour as ``--background`` takes it.
    """

    outside: str = OUTSIDES[0]
    canvas: str = CANVASES[0]
    fill: str = FILLS[0]
    background: str = "none"

    def __post_init__(self) -> None:
        for key, choices in (("outside", OUTSIDES), ("canvas", CANVASES)):
            if getattr(self, key) not in choices:
                raise ValueError(f'"{key}" must be one of {", ".join(choices)}, got {getattr(self, key)!r}')
        try:
            object.__setattr__(self, "fill", checked_fill(self.fill, '"fill"'))
        except InputError as error:
            raise ValueError(str(error)) from None
        if not isinstance(self.background, str):
            raise ValueError(f'"background" must be a colour or "none", got {shown(self.background)}')
        if self.background != "none":
            try:
                parse_colour(self.background)
            except ValueError as error:
                raise ValueError(f'"background": {error}') from None

    @property
    def background_rgba(self) -> tuple[float, float, float, float] | None:
        """Straight RGBA in [0, 1] under the warp, or None (transparent)."""
        return None if self.background == "none" else parse_colour(self.background)


@dataclass(frozen=True)
class Pin:
    """A point of the source (``at``) that the warp takes to ``to``, image pixels."""

    at: tuple[float, float]
    to: tuple[float, float]

    def __post_init__(self) -> None:
        for name in ("at", "to"):
            value = getattr(self, name)
            pair = [finite_number(v) for v in value] if isinstance(value, list | tuple) else []
            if len(pair) != 2 or None in pair:
                raise ValueError(f'"{name}" must be two finite numbers [x, y], got {shown(value)}')
            object.__setattr__(self, name, (pair[0], pair[1]))


@dataclass(frozen=True)
class ViewerSettings:
    """The viewer's own settings (``viewer``): each None when absent or not of its type.

    The viewer checks the words against its own choices (`app.viewer.documents.apply_preferences`);
    a value it does not know is dropped there, as the file may come from another version.
    """

    mode: str | None = None
    content: str | None = None
    distortion: str | None = None
    show_folds: bool | None = None
    show_wireframe: bool | None = None
    show_overlay: bool | None = None
    selected: int | None = None
    power: float | None = None
    shift: str | None = None
    time: float | None = None
    loop: bool | None = None
    fps: float | None = None  # the frame grid of the timeline (`app.viewer.frame_grid`)


#: The type of each `ViewerSettings` value in the file.
_VIEWER_TYPES = {
    "mode": str,
    "content": str,
    "distortion": str,
    "show_folds": bool,
    "show_wireframe": bool,
    "show_overlay": bool,
    "selected": int,
    "power": float,
    "shift": str,
    "time": float,
    "loop": bool,
    "fps": float,
}


@dataclass(frozen=True)
class HistoryStep:
    """One undo or redo step: what one edit of the viewer changes.

    ``power`` and ``shift`` are the ``power`` kernel's settings, kept while another kernel is chosen;
    ``output`` the step's output choices (None in the steps of older sessions, which did not hold
    them: those take the session's); ``pins``, ``max_distortion`` and ``fixed`` the viewer's pins
    (`Pin`), their bound and the control points they hold.
    """

    cage: np.ndarray
    target: np.ndarray
    kernel: str
    power: float
    shift: str
    keyframes: tuple[Keyframe, ...] = ()
    interpolation: str = DEFAULT_INTERPOLATION
    parameterization: str = DEFAULT_PARAMETERIZATION
    fold_free: bool = False
    output: OutputChoice | None = None
    pins: tuple[Pin, ...] = ()
    max_distortion: float | None = None
    fixed: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        if self.kernel not in kernel_names():
            raise ValueError(f"unknown kernel {self.kernel!r}")
        cage, target = np.asarray(self.cage, float), np.asarray(self.target, float)
        if cage.ndim != 2 or cage.shape[1:] != (2,) or len(cage) < 3:
            raise ValueError("cage must be 3 or more [x, y] pairs")
        object.__setattr__(self, "cage", cage)
        object.__setattr__(self, "target", target)
        object.__setattr__(self, "power", float(self.power))
        object.__setattr__(self, "fold_free", self.fold_free is True and self.kernel == "poisson")


@dataclass(frozen=True)
class History:
    """The viewer's undo steps (oldest first) and redo steps (the next one last).

    ``problem`` says why the file's history could not be read (then both are empty): an unreadable
    history loses the steps, never the session.
    """

    undo: tuple[HistoryStep, ...] = ()
    redo: tuple[HistoryStep, ...] = ()
    problem: str = ""


@dataclass(frozen=True)
class Animation:
    """The keyframes (sorted by time) and how the target moves between them."""

    keyframes: tuple[Keyframe, ...] = ()
    interpolation: str = DEFAULT_INTERPOLATION

    def __post_init__(self) -> None:
        object.__setattr__(self, "keyframes", sorted_keyframes(self.keyframes))
        if self.interpolation not in INTERPOLATIONS:
            raise ValueError(
                f'"interpolation" must be one of {", ".join(INTERPOLATIONS)}, got {shown(self.interpolation)}'
            )


@dataclass(frozen=True, eq=False)
class Session:
    """A session: what ``warp --session``, ``animate`` and the viewer read, and the viewer writes.

    Attributes
    ----------
    image : Path
        The source image (a relative path in the file is relative to the file's folder).
    cage, target : ndarray of shape (n, 2)
        Source and target control points, image pixels.
    kernel : KernelChoice
    view : app.render.viewport.View
        The viewer's view: image point (x, y) at window pixel (ox + s x, oy + s y).
    max_edge : float or None
        The mesh's edge length (``mesh``), None for the default.
    fold_free : bool
        Deform by the certified fold-free map (``poisson`` only).
    pins : tuple of Pin
    max_distortion : float or None
        A bound K >= 1 on the warp's distortion, None for none.
    output : OutputChoice
    animation : Animation
    viewer : ViewerSettings
    history : History
    extra : dict
        The file's keys this module does not read, written back unchanged.
    """

    image: Path
    cage: np.ndarray
    target: np.ndarray
    kernel: KernelChoice = field(default_factory=KernelChoice)
    view: View = field(default_factory=View)
    max_edge: float | None = None
    fold_free: bool = False
    pins: tuple[Pin, ...] = ()
    max_distortion: float | None = None
    output: OutputChoice = field(default_factory=OutputChoice)
    animation: Animation = field(default_factory=Animation)
    viewer: ViewerSettings = field(default_factory=ViewerSettings)
    history: History = field(default_factory=History)
    extra: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "image", Path(self.image))
        cage = np.array(self.cage, dtype=np.float64)
        target = np.array(self.target, dtype=np.float64)
        if target.shape != cage.shape:
            raise ValueError(f"target has {len(target)} control points but cage has {len(cage)}")
        object.__setattr__(self, "cage", cage)
        object.__setattr__(self, "target", target)
        if self.max_edge is not None and not (math.isfinite(self.max_edge) and self.max_edge > 0):
            raise ValueError(f"mesh max_edge must be a number > 0, got {shown(self.max_edge)}")
        if not isinstance(self.fold_free, bool):
            raise ValueError(f'"fold_free" must be true or false, got {shown(self.fold_free)}')
        if self.max_distortion is not None and not (
            math.isfinite(self.max_distortion) and self.max_distortion >= 1
        ):
            raise ValueError(f'"max_distortion" must be a number >= 1, got {shown(self.max_distortion)}')
        object.__setattr__(self, "pins", tuple(self.pins))
        for index, keyframe in enumerate(self.animation.keyframes):
            if keyframe.target.shape != cage.shape:
                raise ValueError(
                    f"keyframes[{index}]: target has {len(keyframe.target)} control points "
                    f"but cage has {len(cage)}"
                )
        unread = sorted(set(self.extra) & {*REQUIRED_KEYS, *OPTIONAL_KEYS})
        if unread:
            raise ValueError(f"extra holds key(s) the model reads: {', '.join(unread)}")


# -- reading ------------------------------------------------------------------


def read_session(path: str | os.PathLike) -> Session:
    """Read and validate a session file; `InputError` naming the file and the key if it is bad."""
    path = Path(path)
    return session_from_json(read_json(path), path)


def session_from_json(value, path: Path) -> Session:
    """The `Session` of a parsed session file `path` (for messages and relative image paths)."""
    if not isinstance(value, dict):
        raise InputError(f"{path}: expected a JSON object, got {json_type(value)}")
    missing = [key for key in REQUIRED_KEYS if key not in value]
    if missing:
        raise InputError(f"{path}: missing key(s) {', '.join(missing)}")
    if not isinstance(value["image"], str) or not value["image"]:
        raise InputError(f'{path}: "image" must be a file path, got {value["image"]!r}')
    cage = cage_points(value["cage"], f"{path}: cage")
    target = cage_points(value["target"], f"{path}: target")
    kernel_params = value.get("kernel_params", {})
    if not isinstance(kernel_params, dict):
        raise InputError(f'{path}: "kernel_params" must be an object, got {json_type(kernel_params)}')
    try:
        return Session(
            image=path.parent / value["image"],
            cage=cage,
            target=target,
            kernel=KernelChoice(
                value["kernel"], kernel_params, value.get("parameterization", DEFAULT_PARAMETERIZATION)
            ),
            view=_view(value["view"], path),
            max_edge=_max_edge(value.get("mesh"), path),
            fold_free=value.get("fold_free", False),
            pins=_pins(value.get("pins", []), path),
            max_distortion=_optional_number(value, "max_distortion", path),
            output=OutputChoice(
                value.get("outside", OUTSIDES[0]),
                value.get("canvas", CANVASES[0]),
                value.get("fill", FILLS[0]),
                value.get("background", "none"),
            ),
            animation=_animation(value, len(cage), path),
            viewer=_viewer_settings(value.get("viewer")),
            history=_history(value.get("history")),
            extra={key: item for key, item in value.items() if key not in (*REQUIRED_KEYS, *OPTIONAL_KEYS)},
        )
    except ValueError as error:
        raise InputError(f"{path}: {error}") from None


def _view(value, path: Path) -> View:
    if not isinstance(value, dict) or "scale" not in value or "offset" not in value:
        raise InputError(f'{path}: "view" must be an object {{"scale": s, "offset": [ox, oy]}}')
    scale, offset = finite_number(value["scale"]), value["offset"]
    if scale is None or scale <= 0:
        raise InputError(f"{path}: view scale must be a finite number > 0, got {shown(value['scale'])}")
    if not (
        isinstance(offset, list) and len(offset) == 2 and all(finite_number(v) is not None for v in offset)
    ):
        raise InputError(f"{path}: view offset must be two finite numbers [ox, oy], got {shown(offset)}")
    return View(scale, (float(offset[0]), float(offset[1])))


def _max_edge(value, path: Path) -> float | None:
    if value is None:
        return None
    if not isinstance(value, dict) or "max_edge" not in value:
        raise InputError(f'{path}: "mesh" must be an object {{"max_edge": h}}')
    edge = finite_number(value["max_edge"])
    if edge is None:
        raise InputError(f"{path}: mesh max_edge must be a number > 0, got {shown(value['max_edge'])}")
    return edge


def _optional_number(value: dict, key: str, path: Path) -> float | None:
    if value.get(key) is None:
        return None
    number = finite_number(value[key])
    if number is None:
        raise InputError(f'{path}: "{key}" must be a finite number, got {shown(value[key])}')
    return number


def _pins(value, path: Path) -> tuple[Pin, ...]:
    if not isinstance(value, list):
        raise InputError(f'{path}: "pins" must be a list, got {json_type(value)}')
    pins = []
    for index, item in enumerate(value):
        if not isinstance(item, dict) or set(item) != {"at", "to"}:
            raise InputError(
                f'{path}: pins[{index}]: expected an object with "at" and "to", got {shown(item)}'
            )
        try:
            pins.append(Pin(item["at"], item["to"]))
        except ValueError as error:
            raise InputError(f"{path}: pins[{index}]: {error}") from None
    return tuple(pins)


def _animation(value: dict, count: int, path: Path) -> Animation:
    """The ``keyframes`` (each target of `count` points) and ``interpolation`` of a session."""
    items = value.get("keyframes", [])
    if not isinstance(items, list):
        raise InputError(f'{path}: "keyframes" must be a list, got {json_type(items)}')
    keyframes = []
    for index, item in enumerate(items):
        where = f"{path}: keyframes[{index}]"
        if not isinstance(item, dict) or "time" not in item or "target" not in item:
            raise InputError(f'{where}: expected an object with "time" and "target", got {shown(item)}')
        time = finite_number(item["time"])
        if time is None:
            raise InputError(f"{where}: time must be a number of seconds, got {shown(item['time'])}")
        target = cage_points(item["target"], f"{where}: target")
        if len(target) != count:
            raise InputError(f"{where}: target has {len(target)} control points but cage has {count}")
        try:
            keyframes.append(Keyframe(time, target))
        except ValueError as error:
            raise InputError(f"{where}: {error}") from None
    try:
        keyframes = sorted_keyframes(keyframes)
    except ValueError as error:
        raise InputError(f"{path}: keyframes: {error}") from None
    return Animation(keyframes, value.get("interpolation", DEFAULT_INTERPOLATION))


def _viewer_settings(value) -> ViewerSettings:
    """The ``viewer`` object's settings; a value of another type (or the whole object, if it is
    none) reads as absent."""
    if not isinstance(value, dict):
        return ViewerSettings()
    settings = {}
    for key, kind in _VIEWER_TYPES.items():
        item = value.get(key)
        if kind is float:
            item = finite_number(item)
        elif not isinstance(item, kind) or (kind is int and isinstance(item, bool)):
            item = None
        settings[key] = item
    return ViewerSettings(**settings)


def _history(value) -> History:
    """The ``history`` object's steps; an unreadable one is an empty `History` saying why."""
    if value is None:
        return History()
    try:
        if not isinstance(value, dict):
            raise TypeError(f"expected an object, got {json_type(value)}")
        return History(_steps(value, "undo"), _steps(value, "redo"))
    except (TypeError, ValueError, KeyError, OverflowError) as error:
        return History(problem=str(error))


def _steps(value: dict, name: str) -> tuple[HistoryStep, ...]:
    steps = value.get(name, [])
    if not isinstance(steps, list):
        raise TypeError(f"{name} must be a list")
    result = []
    for index, step in enumerate(steps):
        try:
            result.append(
                HistoryStep(
                    step["cage"],
                    step["target"],
                    step["kernel"],
                    step["power"],
                    step["shift"],
                    tuple(  # the keys below are absent in the steps of older sessions
                        Keyframe(float(item["time"]), np.asarray(item["target"]["control_points"], float))
                        for item in step.get("keyframes", [])
                    ),
                    step.get("interpolation", DEFAULT_INTERPOLATION),
                    step.get("parameterization", DEFAULT_PARAMETERIZATION),
                    step.get("fold_free", False),
                    _step_output(step),
                    tuple(Pin(pin["at"], pin["to"]) for pin in step.get("pins", [])),
                    step.get("max_distortion"),
                    tuple(int(i) for i in step.get("fixed", [])),
                )
            )
        except KeyError as error:
            raise ValueError(f"{name}[{index}]: missing {error}") from None
        except ValueError as error:
            raise ValueError(f"{name}[{index}]: {error}") from None
    return tuple(result)


def _step_output(step: dict) -> OutputChoice | None:
    """A history step's output choices, or None where it holds none (an older session's step)."""
    if not any(key in step for key in OUTPUT_KEYS):
        return None
    defaults = OutputChoice()
    return OutputChoice(*(step.get(key, getattr(defaults, key)) for key in OUTPUT_KEYS))


def existing_image(session: Session, path: str | os.PathLike) -> Path:
    """The image of `session` (read from the session file `path`); `InputError` saying where it was
    looked for if it is not there: a relative ``"image"`` is relative to the session file."""
    image = Path(session.image)
    try:
        missing = not image.exists() and not image.is_symlink()
    except OSError:  # a loop of links, a name too long: reading it says what is wrong
        missing = False
    if missing:
        try:
            written = os.path.relpath(image, Path(path).parent)
        except ValueError:  # on another drive (Windows)
            written = str(image)
        raise InputError(
            f'{path}: its "image" {written!r} is {os.path.abspath(image)}, which does not exist (a relative '
            '"image" is relative to the session file); copy the image there or write its path in "image"'
        )
    return image


# -- writing ------------------------------------------------------------------


def write_session(path: str | os.PathLike, session: Session) -> None:
    """Write a session file atomically; the image path is stored relative to it when possible."""
    path = Path(path)
    try:
        image = os.path.relpath(Path(session.image).resolve(), path.resolve().parent)
    except ValueError:  # another drive on Windows
        image = str(Path(session.image).resolve())
    write_json(path, {"image": image, **session_json(session)})


def session_json(session: Session) -> dict:
    """The JSON object of `session` but its ``image``.  Optional keys at their default that older
    versions did not write (``fill``, ``fold_free``, ...) are left out, as those versions wrote them."""
    value = {
        "cage": {"control_points": session.cage.tolist()},
        "target": {"control_points": session.target.tolist()},
        "kernel": session.kernel.name,
        "view": {"scale": float(session.view.scale), "offset": [float(v) for v in session.view.offset]},
    }
    optional = {
        "kernel_params": session.kernel.params or None,
        "parameterization": session.kernel.parameterization,
        "mesh": None if session.max_edge is None else {"max_edge": float(session.max_edge)},
        "fold_free": session.fold_free or None,
        "pins": [{"at": list(pin.at), "to": list(pin.to)} for pin in session.pins] or None,
        "max_distortion": session.max_distortion,
        "outside": session.output.outside,
        "canvas": session.output.canvas,
        "fill": None if session.output.fill == "none" else session.output.fill,
        "background": None if session.output.background == "none" else session.output.background,
        "keyframes": keyframes_json(session.animation.keyframes),
        "interpolation": session.animation.interpolation,
        "viewer": _viewer_json(session.viewer),
        "history": _history_json(session.history),
    }
    value.update((key, item) for key, item in optional.items() if item is not None)
    value.update(session.extra)
    return value


def _viewer_json(settings: ViewerSettings) -> dict | None:
    value = {key: getattr(settings, key) for key in _VIEWER_TYPES if getattr(settings, key) is not None}
    return value or None


def _history_json(history: History) -> dict | None:
    if not (history.undo or history.redo):
        return None
    return {
        "undo": [_step_json(step) for step in history.undo],
        "redo": [_step_json(step) for step in history.redo],
    }


def _step_json(step: HistoryStep) -> dict:
    return {
        "cage": step.cage.tolist(),
        "target": step.target.tolist(),
        "kernel": step.kernel,
        "power": step.power,
        "shift": step.shift,
        "keyframes": keyframes_json(step.keyframes),
        "interpolation": step.interpolation,
        "parameterization": step.parameterization,
        "fold_free": step.fold_free,
        **({} if step.output is None else {key: getattr(step.output, key) for key in OUTPUT_KEYS}),
        **({"pins": [{"at": list(pin.at), "to": list(pin.to)} for pin in step.pins]} if step.pins else {}),
        **({} if step.max_distortion is None else {"max_distortion": step.max_distortion}),
        **({"fixed": list(step.fixed)} if step.fixed else {}),
    }
