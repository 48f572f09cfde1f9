"""The widgets of the viewer, drawn with imgui-bundle once per frame by `gui`.

`gui(state, shortcuts)` reads `AppState` and returns what the user asked for as
commands ``(name, value)``, the same ones the keyboard produces, which the window
runs through `app.viewer.commands.command` (or handles itself: open, save,
export, quit, play).  Panels: the controls on the left, the status line at the
bottom (kernel, vertices, last precompute time, frame time), a colour bar for the
basis-function and height views, and the help with every shortcut.
"""

from __future__ import annotations

import os

from imgui_bundle import imgui

from app.io.files import CAGE_SUFFIXES, kernel_names
from app.viewer import pin_tool
from app.viewer.controller import STATUS_HEIGHT
from app.viewer.editing import to_window
from app.viewer.file_browser import EXPORT_SUFFIXES, OPEN_SUFFIXES, chosen, current_listing
from app.viewer.file_dialogs import DIALOG_PROGRAMS
from app.viewer.fold_free import HARMONIC_KERNEL, current_check, status_text
from app.viewer.scene import export_frame
from app.viewer.state import PARAMETERIZATIONS, SHIFTS, AppState
from app.viewer.view_modes import BY_NAME as VIEW_MODE
from app.viewer.view_modes import MODES as VIEW_MODES
from app.viewer.view_modes.colours import packed
from app.warp.keyframes import MAX_TIME

PANEL_WIDTH = 300.0

_FIXED = (
    imgui.WindowFlags_.no_move
    | imgui.WindowFlags_.no_resize
    | imgui.WindowFlags_.no_collapse
    | imgui.WindowFlags_.no_saved_settings
)


def gui(
    state: AppState, shortcuts: list[tuple[str, str]], extras: dict | None = None, spots: dict | None = None
) -> list[tuple]:
    """Draw every widget; return the commands the user gave, in order.

    Parameters
    ----------
    state : AppState
    shortcuts : list of (keys, what)
        For the help panel.
    extras : dict, optional
        ``session_saved`` (str), ``script`` (bool: a demo script can be played),
        ``playing`` (bool), ``dialogs`` (bool: a file dialog program exists).
    spots : dict, optional
        Filled with the window points (x, y) of some widgets, ``"kernel"`` (the kernel list) and
        ``"arc-length"`` (that button), which the window tests click; not part of the model.
    """
    extras = extras or {}
    spots = {} if spots is None else spots
    commands: list[tuple] = []
    width, height = state.screen.window_size
    status_height = _status_height(state, width)
    _panel(state, commands, extras, height - status_height, spots)
    _status(state, width, height, status_height, spots)
    _canvas_label(state)
    if state.display.view_mode != "image" and state.compute.basis is not None:
        _colour_bar(state, width, height)
    if state.display.show_help:
        _help(state, shortcuts, width, height)
    for kind in ("open", "export", "cage", "target"):
        if getattr(state.status, f"{kind}_prompt") is not None:
            _path_prompt(state, commands, (width, height), kind, spots)
    return commands


def _path_prompt(
    state: AppState, commands: list[tuple], size: tuple[float, float], kind: str, spots: dict
) -> None:
    """Type a path to open (`kind` "open"), to export to ("export") or to save the cage or the
    target to ("cage", "target"), or pick it in the viewer's own file list
    (`app.viewer.file_browser`), where no file dialog program (zenity, kdialog) is installed."""
    width, height = size
    field = f"{kind}_prompt"
    title, explanation, button, command, suffixes = {
        "open": (
            "Open a file",
            "Path of an image, a session or a cage file (or drop the file on the window):",
            "Open",
            "open_path",
            OPEN_SUFFIXES,
        ),
        "export": (
            "Export the warped image or the animation",
            "Write to (a .png image; the keyframes' animation as .mp4, .gif, or PNG frames in a folder/):",
            "Export",
            "export_path",
            EXPORT_SUFFIXES,
        ),
        "cage": ("Save the cage", _CAGE_FILE_WORDS, "Save", "save_cage", CAGE_SUFFIXES),
        "target": ("Save the target", _CAGE_FILE_WORDS, "Save", "save_target", CAGE_SUFFIXES),
    }[kind]
    imgui.set_next_window_pos((width / 2, height / 3), imgui.Cond_.appearing, (0.5, 0.5))
    imgui.set_next_window_size((min(640.0, 0.9 * width), 0), imgui.Cond_.appearing)
    expanded, opened = imgui.begin(title, True, imgui.WindowFlags_.no_saved_settings)
    if expanded:
        imgui.text_wrapped(explanation)
        imgui.set_next_item_width(-1)
        if imgui.is_window_appearing():
            imgui.set_keyboard_focus_here()
        # The proposed path starts selected, as in a file dialog: typing replaces it.
        flags = imgui.InputTextFlags_.enter_returns_true | imgui.InputTextFlags_.auto_select_all
        entered, text = imgui.input_text(f"##{kind}", getattr(state.status, field), flags)
        text, opened_file = _file_list(text, suffixes, height, spots)
        setattr(state.status, field, text)
        if (entered or opened_file or imgui.button(button)) and text.strip():
            commands.append((command, text.strip()))
            setattr(state.status, field, None)
        imgui.same_line()
        if imgui.button("Cancel"):
            setattr(state.status, field, None)
    imgui.end()
    if opened is False:
        setattr(state.status, field, None)


_CAGE_FILE_WORDS = "Write to (.svg: a path of quadratic Beziers that Inkscape edits; .json: the cage file):"


def _file_list(text: str, suffixes: tuple[str, ...], height: float, spots: dict) -> tuple[str, bool]:
    """The folder of the typed path, listed under the field; the field's new text (a click on an
    entry) and whether a file was double-clicked.  ``spots["files"]`` is the first entry's middle
    height and the rows' pitch (for the window tests; the list is in the window's middle)."""
    listed = current_listing(text, suffixes)
    programs = ", ".join(DIALOG_PROGRAMS)
    imgui.text_disabled(f"no file dialog program ({programs}) is installed: the viewer lists the files")
    imgui.text(f"{listed.folder}{os.sep}" + (f"  ({listed.note})" if listed.note else ""))
    opened = False
    if imgui.begin_child("##files", (0, min(280.0, 0.4 * height)), imgui.ChildFlags_.borders):
        top = imgui.get_cursor_screen_pos().y
        spots["files"] = (top + 0.5 * imgui.get_text_line_height(), imgui.get_text_line_height_with_spacing())
        for entry in listed.entries:
            label = entry.name if entry.folder or entry.name == ".." else f"  {entry.name}"
            clicked, _ = imgui.selectable(
                label, str(entry.path) == text, imgui.SelectableFlags_.allow_double_click
            )
            if clicked:
                text = chosen(entry)
                opened = not entry.folder and imgui.is_mouse_double_clicked(imgui.MouseButton_.left)
    imgui.end_child()
    return text, opened


def _panel(state: AppState, commands: list, extras: dict, room: float, spots: dict) -> None:
    """The side panel, at most `room` pixels tall (the window above the status line): taller
    content scrolls, and a click on the panel never lifts it over the status line."""
    live = state.document.live
    imgui.set_next_window_pos((0, 0))
    # As tall as its content: every pixel of panel costs a software rasteriser time.
    imgui.set_next_window_size_constraints((PANEL_WIDTH, 0), (PANEL_WIDTH, room))
    flags = _FIXED | imgui.WindowFlags_.always_auto_resize | imgui.WindowFlags_.no_bring_to_front_on_focus
    imgui.begin("Transfinite warp", None, flags)
    # A window too short for the whole panel (a 1024x600 screen) opens with two sections folded.
    tall = room + STATUS_HEIGHT >= FOLD_BELOW_HEIGHT
    if _section("Edit", spots):
        _edit_section(state, live, commands, spots)
    if _section("Kernel", spots):
        _kernel_section(state, live, commands, spots)
    if _section("Show", spots, tall):
        _show_section(state, commands)
    if _section("Animation", spots, tall):
        _timeline(state, commands, extras)
    if _section("File", spots):
        _file_section(state, commands, extras, spots)
    state.screen.canvas_left = PANEL_WIDTH
    state.screen.panel_bottom = imgui.get_window_pos().y + imgui.get_window_size().y
    # Its bottom edge and the pixels of content scrolled out of sight (for the window tests).
    spots["panel"] = (state.screen.panel_bottom, imgui.get_scroll_max_y())
    imgui.end()


#: Window height (pixels) below which the panel's "Show" and "Animation" sections open folded.
FOLD_BELOW_HEIGHT = 900


def _section(title: str, spots: dict, open_at_first: bool = True) -> bool:
    """A heading that folds its section (a click); whether the section's widgets are shown.
    Its centre is ``spots[title]`` (for the window tests)."""
    imgui.set_next_item_open(open_at_first, imgui.Cond_.once)
    shown = imgui.collapsing_header(title)
    low, high = imgui.get_item_rect_min(), imgui.get_item_rect_max()
    spots[title] = (0.5 * (low.x + high.x), 0.5 * (low.y + high.y))
    return shown


def _pin_bound(state: AppState, live, commands: list, spots: dict) -> None:
    """The pins' K slider, 1 (rigid) to inf (free), at position 1 - 1/K; one undo step on release.
    Its left and right ends are ``spots["K rigid"]`` and ``spots["K free"]`` (for the window tests)."""
    if state.display.bound_draft is None or not imgui.is_any_item_active():
        state.display.bound_draft = pin_tool.position_of(live.pins.bound)
    imgui.text("rigid")
    imgui.same_line()
    imgui.set_next_item_width(PANEL_WIDTH - 110)
    shown = in_the_font(pin_tool.bound_words(pin_tool.bound_of(state.display.bound_draft)))
    _, state.display.bound_draft = imgui.slider_float("##K", state.display.bound_draft, 0.0, 1.0, shown)
    low, high = imgui.get_item_rect_min(), imgui.get_item_rect_max()
    middle = 0.5 * (low.y + high.y)
    spots["K rigid"], spots["K free"] = (low.x + 4, middle), (high.x - 4, middle)
    if imgui.is_item_deactivated_after_edit():
        commands.append(("max_distortion", pin_tool.bound_of(state.display.bound_draft)))
    if imgui.is_item_hovered():
        imgui.set_tooltip(
            "K bounds sigma1/sigma2 everywhere in the picture, proven: 1 keeps it rigid up to "
            "scale, larger lets it stretch, free sets no bound (the pins land exactly)"
        )
    imgui.same_line()
    imgui.text("free")
    pins, fixed = len(live.pins.points), len(live.pins.fixed)
    imgui.text_disabled(f"{pins} pin{'s' * (pins != 1)}, {fixed} point{'s' * (fixed != 1)} held by hand")


#: The edit modes' radio buttons: mode, label, tooltip.
EDIT_MODES = (
    ("deform", "Deform", "Drag the target cage's points (blue): the picture follows (D)"),
    ("cage", "Cage", "Edit the source cage (green): where the picture is held (C)"),
    ("pins", "Pins", "Pin the picture: click adds a pin, drag moves it, right-click removes (T)"),
)


def _edit_section(state: AppState, live, commands: list, spots: dict) -> None:
    """What a click edits, undo, and the edits of the whole cage."""
    for index, (mode, label, tip) in enumerate(EDIT_MODES):  # one line: the panel fits a 1080p screen
        if index:
            imgui.same_line()
        if imgui.radio_button(label, state.selection.edit_mode == mode):
            commands.append(("edit_mode", mode))
        if imgui.is_item_hovered():
            imgui.set_tooltip(tip)
    if state.selection.edit_mode == "pins" or live.pins.points:
        _pin_bound(state, live, commands, spots)
    if imgui.button("Undo"):
        commands.append(("undo", None))
    imgui.same_line()
    if imgui.button("Redo"):
        commands.append(("redo", None))
    imgui.same_line()
    if imgui.button("Reset target"):
        commands.append(("reset_target", None))
    if imgui.button("Fit cage to subject"):
        commands.append(("fit", None))
    imgui.same_line()
    if imgui.button("Subdivide"):
        commands.append(("subdivide", None))
    if imgui.button("New cage"):
        commands.append(("new_cage", None))
    imgui.same_line()
    imgui.begin_disabled(
        (state.selection.selected is None and not state.selection.group)
        or state.selection.edit_mode != "cage"
    )
    if imgui.button("Delete selected"):
        commands.append(("delete", None))
    imgui.end_disabled()
    _cage_drawing_choice(state, commands)
    if len(state.selection.group) > 1:
        selection = f", {len(state.selection.group)} selected"
    else:
        selection = (
            f", point {state.selection.selected} selected" if state.selection.selected is not None else ""
        )
    imgui.text_disabled(f"{live.n} control points{selection}")


def _kernel_section(state: AppState, live, commands: list, spots: dict) -> None:
    """The kernel, its parameters, and the precompute's progress or error."""
    names = kernel_names()
    spots["kernel"] = tuple(imgui.get_cursor_screen_pos() + imgui.ImVec2(24, 8))
    if imgui.begin_combo("##kernel", live.kernel):
        for name in names:
            clicked, _ = imgui.selectable(name, name == live.kernel)
            if clicked and name != live.kernel:
                commands.append(("kernel", name))
        imgui.end_combo()
    _fold_free_toggle(live, commands)
    if live.kernel == "power":
        # The slider edits a draft; the kernel changes (one undo step, one precompute) on release.
        if state.display.power_draft is None or not imgui.is_any_item_active():
            state.display.power_draft = live.power
        _, state.display.power_draft = imgui.slider_float(
            "power k", state.display.power_draft, 0.5, 8.0, "%.2f"
        )
        if imgui.is_item_deactivated_after_edit():
            commands.append(("power", round(state.display.power_draft, 2)))
        if imgui.begin_combo("shift", live.shift):
            for shift in SHIFTS:
                clicked, _ = imgui.selectable(shift, shift == live.shift)
                if clicked and shift != live.shift:
                    commands.append(("shift", shift))
            imgui.end_combo()
    _parameterization_choice(live, commands, spots)
    if state.compute.progress is not None:
        # The phase on its own wrapped line: centred in the bar, a long one lost its first letters.
        imgui.push_text_wrap_pos(PANEL_WIDTH - 12)
        imgui.text(state.compute.progress_label)
        imgui.pop_text_wrap_pos()
        imgui.progress_bar(state.compute.progress, (-1, 0), f"{100 * state.compute.progress:.0f}%")
    elif state.compute.basis_error:
        imgui.push_text_wrap_pos(PANEL_WIDTH - 12)
        imgui.text_colored((1.0, 0.45, 0.4, 1.0), state.compute.basis_error)
        imgui.pop_text_wrap_pos()
    if state.compute.basis is not None and state.compute.basis.kernel != live.kernel:
        imgui.push_text_wrap_pos(PANEL_WIDTH - 12)
        imgui.text_disabled(f"showing {state.compute.basis.kernel} until {live.kernel} is ready")
        imgui.pop_text_wrap_pos()


def _show_section(state: AppState, commands: list) -> None:
    """What the canvas shows, and what exports frame."""
    for mode in VIEW_MODES:
        if imgui.radio_button(mode.label, state.display.view_mode == mode.name):
            commands.append(("view_mode", mode.name))
    if state.display.view_mode == "distortion":
        _choice_row(
            commands,
            "  measure:",
            "distortion_measure",
            state.display.distortion_measure,
            (("area", "area"), ("conformal", "angles")),
            "area: log2 det J, the area change; angles: log2 sigma1/sigma2, how much the\n"
            "stretch differs between directions. Folded vertices (det J <= 0) are black.",
        )
    for field, label in (
        ("show_folds", "Folded triangles"),
        ("show_wireframe", "Mesh edges"),
        ("show_overlay", "Curves and handles"),
    ):
        changed, _ = imgui.checkbox(label, getattr(state.display, field))
        if changed:
            commands.append(("toggle", field))
    if state.document.outside == "transparent":
        imgui.set_next_item_width(150)
        _, state.display.backdrop_opacity = imgui.slider_float(
            "source image", state.display.backdrop_opacity, 0.0, 1.0, "%.2f"
        )
    _choice_row(
        commands,
        "Outside:",
        "outside",
        state.document.outside,
        (("transparent", "transparent"), ("original", "original")),
        "original: the untouched picture around the warp (inside the source cage, where the target does "
        "not cover it, the original is seen); exports and warp --outside do the same",
    )
    if state.document.outside == "original":
        _fill_choice(state, commands)
    _choice_row(
        commands,
        "Background:",
        "background",
        state.document.background,
        (("none", "none"), ("white", "white"), ("black", "black")),
        "what exports show where the warp leaves them transparent (needed for JPEG); another colour: "
        'the session\'s "background" ("#rrggbb"); warp and animate --background do the same',
    )
    _choice_row(
        commands,
        "Canvas: ",
        "canvas",
        state.document.canvas,
        (("source", "source"), ("grow", "grow")),
        "what exports frame: source, the image (a target leaving it is cut off), or grow, the image and "
        "the whole target curve; warp --canvas and animate --canvas do the same",
    )
    if imgui.button("Fit view"):
        commands.append(("fit_view", None))
    if state.compute.folded_count:
        imgui.text_colored((1.0, 0.5, 0.8, 1.0), f"{state.compute.folded_count} folded triangles")


def _file_section(state: AppState, commands: list, extras: dict, spots: dict) -> None:
    """Open, save, export, start over, save the cage or the target, the demo script, help and quit.
    The Save target button's centre is ``spots["save target"]`` (for the window tests)."""
    if imgui.button("Open image..."):
        commands.append(("open", None))
    imgui.same_line()
    if imgui.button("Open session..."):
        commands.append(("open_session", None))
    if imgui.button("Save"):
        commands.append(("save", None))
    imgui.same_line()
    if imgui.button("Export..."):
        commands.append(("export", None))
    imgui.same_line()
    if imgui.button("Start over"):
        commands.append(("start_over", None))
    if imgui.is_item_hovered():
        imgui.set_tooltip("a new start from the opening cage (or a fitted one); Ctrl+Z goes back")
    for which in ("cage", "target"):
        if which == "target":
            imgui.same_line()
        if imgui.button(f"Save {which}..."):
            commands.append((f"save_{which}", None))
        low, high = imgui.get_item_rect_min(), imgui.get_item_rect_max()
        spots[f"save {which}"] = (0.5 * (low.x + high.x), 0.5 * (low.y + high.y))
        if imgui.is_item_hovered():
            imgui.set_tooltip(f"write the {which} as an SVG path (or .json); Open reads it back")
    if extras.get("script"):
        if imgui.button("Stop script" if extras.get("playing") else "Play demo script"):
            commands.append(("play", None))
    imgui.push_text_wrap_pos(PANEL_WIDTH - 12)
    imgui.text_disabled(f"session: {state.document.session_path}")
    imgui.pop_text_wrap_pos()
    if imgui.button("Help (F1)"):
        commands.append(("help", None))
    imgui.same_line()
    if imgui.button("Quit"):
        commands.append(("quit", None))


#: Window pixels of the timeline strip.
TIMELINE_HEIGHT = 26.0
#: A click this close (window pixels) to a keyframe's mark selects it instead of seeking.
KEYFRAME_PICK = 6.0


def timeline_end(state: AppState) -> float:
    """The time (seconds) at the right end of the timeline: past the last keyframe and the current time."""
    span = state.document.live.time_span
    last = span[1] if span else 0.0
    return max(1.0, 1.1 * last, state.playback.time)


def _timeline(state: AppState, commands: list, extras: dict) -> None:
    """Keyframes on a strip of time: click or drag to scrub, click a mark to select its keyframe."""
    live = state.document.live
    if imgui.button("Pause" if state.playback.playing else "Play"):
        commands.append(("playback", None))
    imgui.same_line()
    if imgui.button("Keyframe"):
        commands.append(("add_keyframe", None))
    if imgui.is_item_hovered():
        imgui.set_tooltip("a keyframe at the current time from the target shown (I); one there is replaced")
    imgui.same_line()
    imgui.begin_disabled(state.playback.keyframe is None)
    if imgui.button("Delete key"):
        commands.append(("delete_keyframe", None))
    imgui.end_disabled()

    end = timeline_end(state)
    left, top = imgui.get_cursor_screen_pos()
    width = PANEL_WIDTH - 2 * imgui.get_style().window_padding.x
    imgui.invisible_button("##timeline", (width, TIMELINE_HEIGHT))
    marks = [left + width * keyframe.time / end for keyframe in live.keyframes]
    if imgui.is_item_activated():
        x = imgui.get_io().mouse_pos.x
        near = [i for i, mark in enumerate(marks) if abs(mark - x) <= KEYFRAME_PICK]
        if near:
            commands.append(("select_keyframe", min(near, key=lambda i: abs(marks[i] - x))))
        else:
            commands.append(("seek", end * (x - left) / width))
    elif imgui.is_item_active() and imgui.get_io().mouse_delta.x != 0:
        x = min(max(imgui.get_io().mouse_pos.x, left), left + width)
        commands.append(("seek", end * (x - left) / width))
    draw = imgui.get_window_draw_list()
    middle = top + TIMELINE_HEIGHT / 2
    draw.add_rect_filled((left, top), (left + width, top + TIMELINE_HEIGHT), packed((0.2, 0.2, 0.23)))
    for second in range(int(end) + 1):
        x = left + width * second / end
        draw.add_line((x, top + TIMELINE_HEIGHT - 6), (x, top + TIMELINE_HEIGHT), packed((0.6, 0.6, 0.6)))
    for index, x in enumerate(marks):
        colour = (1.0, 0.86, 0.2) if index == state.playback.keyframe else (0.22, 0.48, 1.0)
        size = 7.0 if index == state.playback.keyframe else 5.5
        corners = [(x, middle - size), (x + size, middle), (x, middle + size), (x - size, middle)]
        draw.add_quad_filled(*corners, packed(colour))
    now = left + width * state.playback.time / end
    draw.add_line((now, top), (now, top + TIMELINE_HEIGHT), packed((1.0, 1.0, 1.0)), 2.0)

    span = live.time_span
    total = f" of {span[0]:.2f}..{span[1]:.2f} s" if span else ", no keyframes"
    imgui.text(f"t = {state.playback.time:.2f} s{total}")
    if state.playback.keyframe is not None and state.playback.keyframe < len(live.keyframes):
        keyframe_time = live.keyframes[state.playback.keyframe].time
        # The field edits a draft; the keyframe moves (one undo step) when it is released.
        if state.playback.time_draft is None or not imgui.is_any_item_active():
            state.playback.time_draft = keyframe_time
        imgui.set_next_item_width(120)
        _, state.playback.time_draft = imgui.drag_float(
            "keyframe time (s)", state.playback.time_draft, 0.01, 0.0, MAX_TIME, "%.2f"
        )
        if imgui.is_item_deactivated_after_edit():
            commands.append(("keyframe_time", (state.playback.keyframe, round(state.playback.time_draft, 3))))
    changed, _ = imgui.checkbox("Loop", state.playback.loop)
    if changed:
        commands.append(("toggle", "loop"))
    imgui.same_line()
    for name, label in (("catmull-rom", "smooth"), ("linear", "linear")):
        imgui.same_line()
        if imgui.radio_button(label, live.interpolation == name):
            commands.append(("interpolation", name))
    if imgui.is_item_hovered():
        imgui.set_tooltip("between keyframes: smooth (Catmull-Rom, C1 in time) or linear (constant speed)")
    if extras.get("exporting") is not None:
        imgui.progress_bar(
            extras["exporting"], (-1, 0), f"exporting {100 * extras['exporting']:.0f}% (Esc stops)"
        )


def _choice_row(commands: list, title: str, command: str, current: str, choices: tuple, tooltip: str) -> None:
    """`title` and one radio button per (value, label) of `choices` on one line; a click gives
    the command ``(command, value)``.  `tooltip` shows over the row's last button."""
    imgui.text(title)
    for value, label in choices:
        imgui.same_line()
        if imgui.radio_button(label, current == value):
            commands.append((command, value))
    if imgui.is_item_hovered():
        imgui.set_tooltip(tooltip)


def status_kernel(state: AppState) -> str:
    """The status line's kernel: the one drawn, and the one being computed while they differ."""
    live = state.document.live
    wanted = live.kernel + (f" (k={live.power:g}, shift {live.shift})" if live.kernel == "power" else "")
    if state.compute.basis is None or state.compute.basis.kernel == live.kernel:
        return wanted
    return f"{state.compute.basis.kernel}, switching to {wanted}..."


def _canvas_label(state: AppState) -> None:
    """Name the grey frame of what an export holds (`scene.export_frame`) at its top-left corner."""
    frame = export_frame(state) if state.display.show_overlay else None
    if frame is None:
        return
    x, y = to_window(state.display.viewport, frame[:1])[0]
    colour = imgui.get_color_u32((0.85, 0.85, 0.85, 0.9))
    imgui.get_background_draw_list().add_text(
        (float(x) + 4, float(y) + 2), colour, f"canvas: {state.document.canvas}"
    )


def status_summary(state: AppState) -> str:
    """The status line's figures: kernel, mesh, zoom, the precompute time of the basis drawn, and the
    median frame times ``--stats`` reports (all frames, and the frames of drags)."""
    kernel = status_kernel(state)
    basis = state.compute.basis
    vertices = f"{len(basis.mesh.vertices):,} vertices" if basis is not None else "no mesh yet"
    if basis is not None and basis.preview is not None:
        vertices += f" ({len(basis.preview.vertices):,} while moving)"
    precompute = f"precompute {basis.seconds:.2f} s" if basis is not None else "precompute -"
    frame = "frame -"
    if state.status.frame_figures is not None:
        median, drag = state.status.frame_figures
        frame = f"frame {median:.1f} ms" + (f", dragging {drag:.1f} ms" if drag > 0 else "")
    return (
        f"{kernel} | {vertices} | zoom {100 * state.display.viewport.scale:.0f} % | {precompute} | {frame} | "
        f"{status_check(state)}"
    )


def status_check(state: AppState) -> str:
    """What is proven about the warp shown (`app.viewer.fold_free`, `app.viewer.fold_free_frames`):
    of the live target only.  With fold-free on, the mesh map's proof comes first ("fold-free on
    the mesh, proven"), the continuous map's certificate after it ("fold-free, proven (σ₂ ≥ …)")."""
    live = state.document.live
    if live.kernel != HARMONIC_KERNEL:
        return f"no fold-free proof ({HARMONIC_KERNEL} only)"
    if state.selection.drawing is not None:
        return "fold-free: -"  # nothing is checked while a new cage is drawn
    check = current_check(state)
    proof = state.compute.mesh_proof
    on_mesh = live.fold_free and proof is not None and proof.proves(live.target)
    if check is not None and on_mesh and check.fold_free and check.positions is None:
        return f"{MESH_PROVEN}; no continuous proof: {check.text}"
    if check is not None:
        return status_text(check, state.compute.folded_count)
    if state.compute.basis is None:
        return "fold-free: -"
    if not live.fold_free:
        return "checking folds..."
    share = state.compute.check_progress
    if share is None:
        continuous = "computing the fold-free map..."
    elif share >= 0.995:  # the path is done; its certificate and the mesh's repair take a while more
        continuous = "proving the fold-free map..."
    else:
        continuous = f"fold-free map: {100 * share:.0f} % of the way"
    if on_mesh:
        return f"{MESH_PROVEN}; {continuous}"
    if proof is not None and not proof.reached:
        return "fold-free on the mesh, catching up with the drag..."
    return continuous


#: The status line's words for a mesh map proven a bijection (`app.viewer.fold_free_frames`).
MESH_PROVEN = "fold-free on the mesh, proven"


def _fold_free_toggle(live, commands: list) -> None:
    """The "Fold-free" switch (B), for the harmonic kernel only."""
    imgui.begin_disabled(live.kernel != HARMONIC_KERNEL)
    changed, _ = imgui.checkbox("Fold-free (proven)", live.fold_free)
    if changed:
        commands.append(("fold_free", None))
    imgui.end_disabled()
    if imgui.is_item_hovered(imgui.HoveredFlags_.allow_when_disabled):
        imgui.set_tooltip(
            "a warp that provably never folds and still meets the target curve (B): every frame of a drag\n"
            "is proven fold-free on the mesh, the continuous map after it; saved in the session for warp\n"
            f"and animate; needs the {HARMONIC_KERNEL} kernel"
        )


#: What the status line writes for the symbols imgui's default font has no glyph for (it would
#: draw "?"): the certificate's and the core's messages use them.
FONT_SPELLINGS = {
    "σ₁": "sigma1",
    "σ₂": "sigma2",
    "≥": ">=",
    "≤": "<=",
    "×": "x",
    "…": "...",
    "–": "-",
    "—": "-",
    "→": "->",
    "∞": "inf",
}


def in_the_font(text: str) -> str:
    """`text` with the symbols of `FONT_SPELLINGS` spelled in ASCII."""
    for symbol, spelling in FONT_SPELLINGS.items():
        text = text.replace(symbol, spelling)
    return text


def _status_lines(state: AppState, width: float) -> tuple[str, str, bool, float]:
    """The status line's summary and message, whether they share one line, and the height the
    wrapped lines above the last take (0 when all fits on one line)."""
    summary = in_the_font(status_summary(state))
    message = in_the_font(state.status_message())
    room = width - 2 * imgui.get_style().window_padding.x
    spacing = imgui.get_style().item_spacing.x
    inline = not message or imgui.calc_text_size(f"{summary} | {message}").x + spacing <= room
    wrapped = imgui.calc_text_size(summary, wrap_width=room).y - imgui.get_text_line_height()
    if not inline:
        wrapped += imgui.calc_text_size(message, wrap_width=room).y + spacing
    return summary, message, inline, max(wrapped, 0.0)


def _status_height(state: AppState, width: float) -> float:
    """Window pixels the status line takes at the window's bottom (more than one line when its
    words do not fit the window's width)."""
    return STATUS_HEIGHT + _status_lines(state, width)[3]


def _status(state: AppState, width: float, height: float, status_height: float, spots: dict) -> None:
    """The status line: kernel, mesh, zoom, timings and the last message.

    A message too long for the line goes on lines of its own above it, and a summary too long
    for the window wraps, instead of being cut at the window's edge; the panel stays above it
    (`_panel`).  Its top is ``spots["status"]`` (for the window tests).
    """
    summary, message, inline, _ = _status_lines(state, width)
    imgui.set_next_window_pos((0, height - status_height))
    imgui.set_next_window_size((width, status_height))
    imgui.begin("##status", None, _FIXED | imgui.WindowFlags_.no_title_bar | imgui.WindowFlags_.no_scrollbar)
    colour = (1.0, 0.45, 0.4, 1.0) if state.status.message_is_error else (0.75, 0.85, 1.0, 1.0)
    imgui.push_text_wrap_pos(0.0)
    if message and not inline:
        imgui.text_colored(colour, message)
    imgui.text(summary)
    imgui.pop_text_wrap_pos()
    if message and inline:
        imgui.same_line()
        imgui.text_colored(colour, f"| {message}")
    spots["status"] = (0.0, height - status_height)
    imgui.end()


def _colour_bar(state: AppState, width: float, height: float) -> None:
    """The legend of the view shown (`app.viewer.view_modes`), at the canvas's bottom right."""
    mode = VIEW_MODE[state.display.view_mode]
    if mode.legend is None:
        return
    bar_width, bar_height = 240.0, mode.legend_height
    imgui.set_next_window_pos((width - bar_width - 10, height - STATUS_HEIGHT - bar_height - 10))
    imgui.set_next_window_size((bar_width, bar_height))
    imgui.begin("##colour bar", None, _FIXED | imgui.WindowFlags_.no_title_bar | imgui.WindowFlags_.no_inputs)
    left, top = imgui.get_cursor_screen_pos()
    mode.legend(state, imgui.get_window_draw_list(), left, top, bar_width - 24)
    imgui.end()


def _help(state: AppState, shortcuts: list[tuple[str, str]], width: float, height: float) -> None:
    imgui.set_next_window_pos((width / 2, height / 2), imgui.Cond_.appearing, (0.5, 0.5))
    imgui.set_next_window_size((min(780.0, 0.9 * width), 0), imgui.Cond_.appearing)
    expanded, opened = imgui.begin("Help", True, imgui.WindowFlags_.no_saved_settings)
    if expanded:
        imgui.text_wrapped(
            "Transfinite barycentric image deformation (Chang & Hormann). The green curve is the "
            "source cage around the image, the blue one the target: drag blue handles to deform. "
            "In cage mode, drag green handles, click to add a point, right-click a point to delete it. "
            "In pins mode (T), click to pin the picture, drag a pin and it follows; the K slider bounds "
            "its distortion, from rigid to free."
        )
        imgui.separator()
        if imgui.begin_table("shortcuts", 2, imgui.TableFlags_.row_bg | imgui.TableFlags_.borders_inner_v):
            imgui.table_setup_column("keys", imgui.TableColumnFlags_.width_fixed, 170)
            imgui.table_setup_column("what", imgui.TableColumnFlags_.width_stretch)
            for keys, what in shortcuts:
                imgui.table_next_row()
                imgui.table_next_column()
                imgui.text(keys)
                imgui.table_next_column()
                imgui.text_wrapped(what)  # long descriptions wrap instead of being cut off
            imgui.end_table()
    imgui.end()
    if opened is False:
        state.display.show_help = False


def _parameterization_choice(live, commands: list, spots: dict) -> None:
    """The boundary parameter of the point kernels (Fig. 12); greyed for harmonic and pgw.
    Its last button's centre is ``spots["arc-length"]`` (for the window tests)."""
    imgui.begin_disabled(not live.parameterized)
    _choice_row(
        commands,
        "boundary",
        "parameterization",
        live.parameterization,
        tuple(zip(PARAMETERIZATIONS, ("natural", "arc length"), strict=True)),
        "the parameter of the kernel's boundary integrals: the B-spline's own or the arc length "
        "(the paper's Fig. 12); harmonic and pgw do not depend on it",
    )
    low, high = imgui.get_item_rect_min(), imgui.get_item_rect_max()
    spots["arc-length"] = (0.5 * (low.x + high.x), 0.5 * (low.y + high.y))
    imgui.end_disabled()


#: The fill combo's entries: (value, label); a colour is the last one.
FILL_CHOICES = (("none", "original kept"), ("transparent", "transparent"), ("inpaint", "inpainted"))


def _fill_choice(state: AppState, commands: list) -> None:
    """What fills the subject's original position behind the warp (`app.warp.fill`): a list, and a
    colour picker when the fill is a colour."""
    labels = dict(FILL_CHOICES)
    fill = state.document.fill
    colour = fill.startswith("#")
    imgui.text("  fill:")
    imgui.same_line()
    imgui.set_next_item_width(130)
    if imgui.begin_combo("##fill", "colour" if colour else labels[fill]):
        for value, label in (*FILL_CHOICES, ("#ffffff", "colour")):
            clicked, _ = imgui.selectable(label, value == fill or (colour and value == "#ffffff"))
            if clicked and not (colour and value == "#ffffff"):
                commands.append(("fill", value))
        imgui.end_combo()
    if imgui.is_item_hovered():
        imgui.set_tooltip(
            "what shows where the subject was (inside the source cage) when the warp moves it away;\n"
            "exports, warp --fill and animate do the same"
        )
    if colour:
        imgui.same_line()
        rgba = [int(fill[i : i + 2], 16) / 255 for i in range(1, len(fill), 2)] + [1.0]
        changed, picked = imgui.color_edit4("##fill colour", rgba[:4], imgui.ColorEditFlags_.no_inputs)
        if changed:
            commands.append(("fill", "#" + "".join(f"{round(255 * v):02x}" for v in picked)))


def _cage_drawing_choice(state: AppState, commands: list) -> None:
    """What a click places while a new cage is drawn (`app.viewer.drawing.STYLES`)."""
    _choice_row(
        commands,
        "clicks:",
        "cage_drawing",
        state.selection.cage_drawing,
        (("curve", "on curve"), ("control", "control points")),
        "New cage: the curve passes through the points clicked (as GIMP's and Krita's paths), or the\n"
        "clicks are its control points; Ctrl+click or a double click makes a sharp corner either way",
    )
