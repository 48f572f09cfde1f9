"""The viewer's exports (Ctrl+E): the warped image at the image's full resolution, like
``warp --session``, or the keyframed animation, like ``animate``, as many frames as fit in
`EXPORT_BUDGET` between two frames the viewer draws (Esc stops it).  Both draw and write through
`app.warp.pipeline.write_frames` on the window's renderer, as ``warp`` and ``animate`` do, so they
are their files."""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.io.files import IMAGE_SUFFIXES, image_metadata
from app.viewer.file_dialogs import FileRequests
from app.viewer.state import AppState
from app.warp.framing import output_frame, output_region

#: Seconds of an animation export's frames rendered between two window frames (the window's own
#: frame costs as much as several exported ones on a software rasteriser).
EXPORT_BUDGET = 0.25


@dataclass
class AnimationExport:
    """An animation export in progress in the viewer: frames written between drawn frames.

    Attributes
    ----------
    steps : iterator of int
        `app.warp.pipeline.write_frames` of the export: each step draws a frame and gives how many
        are written.
    path : Path
    frames : int
        How many frames the animation has.
    written : int
        Frames written so far.
    """

    steps: Iterator[int]
    path: Path
    frames: int
    written: int = 0


class Exporter:
    """Ctrl+E and Ctrl+Shift+E of one viewer.

    Parameters
    ----------
    state : AppState
    scene : app.viewer.scene.Scene
        Holds the window's renderer and the mesh it draws.
    ready : callable
        ``ready(state)``: whether the basis drawn is the live snapshot's.
    path : Path, optional
        Where Ctrl+E writes (``--export``); default: ask.
    fps : float
        Frames per second of an animation export.
    announce : callable
        Called with one line per export (the window tests read them).
    dialogs : FileRequests
    """

    def __init__(
        self,
        state: AppState,
        scene,
        ready: Callable[[AppState], bool],
        path: Path | None,
        fps: float,
        announce: Callable[[str], None],
        dialogs: FileRequests,
    ):
        self.state, self.scene, self.ready = state, scene, ready
        self.path, self.fps = path, fps
        self.announce, self.dialogs = announce, dialogs
        # Where the last export went, as typed (a folder of frames ends in a slash).
        self.last: str | None = None if path is None else str(path)
        self.animation: AnimationExport | None = None

    @property
    def progress(self) -> float | None:
        """The fraction of the animation export written, None when none runs."""
        return None if self.animation is None else self.animation.written / self.animation.frames

    def ask_path(self, again: bool = False) -> None:
        """Ctrl+E: where to write (``--export`` if given, else a save dialog or the in-window
        prompt); `again` (Ctrl+Shift+E) writes to the last file without asking."""
        if again and self.last is not None:
            self.export(Path(self.last).expanduser(), self.last)
            return
        if self.path is not None:
            self.export(self.path)
            return
        proposed = self.last or default_export_path(self.state.document.live.image)
        self.dialogs.ask_export(self.state, proposed)

    def export(self, path: Path, typed: str | None = None) -> Path | None:
        """Write the warped image at the image's full resolution, like ``warp --session``.

        A name ending in .mp4 or .gif, or in a slash (`typed`, the text as typed),
        starts exporting the animation instead, like ``animate``: one frame per
        drawn frame of the viewer, until it is complete (Esc stops it).
        """
        state = self.state
        if path.suffix.lower() in (".mp4", ".gif") or (typed or "").endswith(("/", os.sep)):
            self._start_animation(path, typed)
            return None
        if path.suffix.lower() not in IMAGE_SUFFIXES:
            path = path.with_name(path.name + ".png")
        try:
            written = self.write_still(path)
        except (ValueError, MemoryError) as error:  # too large an output, or a file not written
            state.say(str(error), error=True)
            return None
        if not written:
            state.say("nothing to export yet: the basis functions are still being computed", error=True)
            return None
        self.last = str(path)
        state.say(f"exported {path} (Ctrl+Shift+E writes it again)")
        self.announce(f"exported {path}")
        return path

    def write_still(self, path: Path) -> bool:
        """Write the live target's warp to `path` as ``warp --session`` does (`write_frames`: the
        image's depth, ICC profile and EXIF, strips for a large PNG); False before its basis is ready.

        Raises
        ------
        ValueError
            An output over `app.warp.framing.MAX_OUTPUT_PIXELS`.
        MemoryError
            Too little address space to draw it (`app.render.renderer.require_render_memory`).
        InputError
            The file cannot be written (transparent pixels for a JPEG, a folder that is not there...).
        """
        still = self._still()
        if still is None:
            return False
        from app.warp.pipeline import FrameOutput, OutputFile, write_frames

        deformation, target, (size, view) = still
        state = self.state
        metadata = image_metadata(state.document.live.image)
        file = OutputFile(path, metadata, background=document_background(state))
        output = FrameOutput(file, "image", size, view, state.document.outside)
        for _ in write_frames(self.scene.renderer, deformation, [target], output):
            pass
        return True

    def render_still(self) -> np.ndarray | None:
        """The live target's warp framed like ``warp`` (RGBA (H, W, 4)), None before its basis is ready."""
        still = self._still()
        if still is None:
            return None
        from app.warp.pipeline import render

        deformation, target, (size, view) = still
        outside, background = self.state.document.outside, document_background(self.state)
        return render(self.scene.renderer, deformation, target, size, view, outside, background)

    def _still(self):
        """The live target's deformation, the target and its output frame (size, view) framed like
        ``warp``, with the scene's positions to be drawn again; None before its basis is ready."""
        state = self.state
        if not self.ready(state):
            return None
        deformation = self.scene.deformation(state)
        if deformation is None:
            return None
        self.scene.invalidate_positions()
        height, width = state.document.image.shape[:2]
        target = state.document.live.target
        return (
            deformation,
            target,
            output_frame(output_region((width, height), target, state.document.canvas)),
        )

    def cancel(self) -> bool:
        """Esc: stop the animation export, if one runs (nothing is written)."""
        if self.animation is None:
            return False
        self.animation.steps.close()
        self.animation = None
        self.state.say("animation export stopped; nothing was written")
        return True

    def _start_animation(self, path: Path, typed: str | None) -> None:
        from app.warp.frame_writers import check_output, output_kind
        from app.warp.framing import frame_region
        from app.warp.keyframes import frame_times, interpolate
        from app.warp.pipeline import FrameOutput, OutputFile, write_frames

        state = self.state
        live = state.document.live
        if not live.keyframes:
            state.say("no keyframes to export: add some first (I, or the Keyframe button)", error=True)
            return
        if not self.ready(state) or not self.scene.mesh_matches(state):
            state.say("nothing to export yet: the basis functions are still being computed", error=True)
            return
        deformation = state.compute.basis.deformation(fold_free=live.fold_free)
        try:
            kind = output_kind(path, typed)
            check_output(path, kind)
            times = frame_times(live.keyframes, self.fps)
            height, width = state.document.image.shape[:2]
            canvas = state.document.canvas
            size, view = output_frame(
                frame_region((width, height), live.keyframes, live.interpolation, times, canvas)
            )
            targets = [interpolate(live.keyframes, float(moment), live.interpolation) for moment in times]
            file = OutputFile(path, image_metadata(live.image), background=document_background(state))
            output = FrameOutput(file, kind, size, view, state.document.outside, self.fps)
            steps = write_frames(self.scene.renderer, deformation, targets, output)
        except (ValueError, MemoryError, OSError) as error:
            state.say(str(error), error=True)
            return
        state.playback.playing = False
        self.animation = AnimationExport(steps, path, len(targets))
        self.last = str(path) + os.sep if kind == "png" else str(path)
        state.say(f"exporting {len(targets)} frames to {path} (Esc stops)")

    def next_frame(self) -> None:
        """Draw and write the next frames of the animation being exported (`write_frames`'s steps), for
        `EXPORT_BUDGET` seconds (a window frame between them keeps the progress shown and Esc heard);
        the file appears after the last."""
        export, state = self.animation, self.state
        if export is None:
            return
        self.scene.invalidate_positions()
        started = time.perf_counter()
        try:
            for written in export.steps:
                export.written = written
                if time.perf_counter() - started >= EXPORT_BUDGET:
                    return
        except (OSError, ValueError) as error:
            self.animation = None
            state.say(f"cannot export the animation: {error}", error=True)
            return
        self.animation = None
        state.say(f"exported {export.frames} frames to {export.path}")
        self.announce(f"exported {export.path}")


def document_background(state: AppState) -> tuple[float, float, float, float] | None:
    """The document's ``background`` as straight RGBA in [0, 1], None for ``"none"`` (transparent)."""
    from app.io.images.colours import parse_colour

    background = state.document.background
    return None if background == "none" else parse_colour(background)


def default_export_path(image: Path) -> Path:
    """Where Ctrl+E proposes to write: ``STEM-warped.png`` beside the image, numbered if it exists;
    in the current folder for a bundled demo (inside the installed package) or a read-only folder."""
    from app.viewer.demos import is_demo_file

    image = Path(image)
    if is_demo_file(image) or not os.access(image.parent, os.W_OK):
        image = Path.cwd() / image.name
    for number in range(1, 1000):
        suffix = "" if number == 1 else f"-{number}"
        path = image.with_name(f"{image.stem}-warped{suffix}.png")
        if not path.exists():
            return path
    return image.with_name(f"{image.stem}-warped.png")
