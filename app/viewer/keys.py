"""The viewer's key bindings, in one place (napari's key bindings module): each key and modifier
gives a named command of `app.viewer.commands`, and the help lists them with the mouse's."""

from __future__ import annotations

from app.viewer.view_modes import MODES as VIEW_MODES

#: What the pin tool's key says in the help.
PINS_HELP = (
    "pins: click in the picture to pin it there, drag a pin and the picture follows, right-click or "
    "Delete removes one; the panel's K slider bounds the distortion (1 rigid ... free: no bound); a blue "
    "point moved by hand is held (orange) by later solves"
)


def key_table() -> list[tuple]:
    """Every key binding: (glfw key, modifiers, command, value, keys shown in the help or None,
    what it does or None).  The commands are `app.viewer.commands.COMMANDS`' names."""
    import glfw

    ctrl, shift = glfw.MOD_CONTROL, glfw.MOD_SHIFT
    # (key, modifiers, command, value, keys shown in the help, what it does)
    return [
        (glfw.KEY_Z, ctrl, "undo", None, "Ctrl+Z", "undo the last edit"),
        (glfw.KEY_Z, ctrl | shift, "redo", None, "Ctrl+Shift+Z, Ctrl+Y", "redo"),
        (glfw.KEY_Y, ctrl, "redo", None, None, None),
        (glfw.KEY_ESCAPE, 0, "cancel", None, "Esc", "cancel the drag in progress, close a list or the help"),
        (glfw.KEY_O, ctrl, "open", None, "Ctrl+O", "open an image (or drop a file on the window)"),
        (glfw.KEY_O, ctrl | shift, "open_session", None, "Ctrl+Shift+O", "open a session file"),
        (glfw.KEY_S, ctrl, "save", None, "Ctrl+S", "save the session now (it also saves itself)"),
        (
            glfw.KEY_E,
            ctrl,
            "export",
            None,
            "Ctrl+E",
            "export the warped image as PNG, full resolution, or the animation (name it .mp4, .gif, folder/)",
        ),
        (glfw.KEY_E, ctrl | shift, "export", "again", "Ctrl+Shift+E", "export again to the last file"),
        (glfw.KEY_Q, ctrl, "quit", None, "Ctrl+Q", "quit"),
        (glfw.KEY_TAB, 0, "edit_mode", None, "Tab", "switch between deforming and editing the cage"),
        (glfw.KEY_D, 0, "edit_mode", "deform", "D", "deform: drag the blue target points"),
        (
            glfw.KEY_C,
            0,
            "edit_mode",
            "cage",
            "C",
            "cage: drag green points, click to add, right-click to delete",
        ),
        (glfw.KEY_T, 0, "edit_mode", "pins", "T", PINS_HELP),
        (
            glfw.KEY_N,
            0,
            "new_cage",
            None,
            "N",
            "draw a new cage: click to place points (Ctrl+click or a "
            "double click: a sharp corner), click the first point or Enter to close, Enter again to use it, "
            "Backspace removes the last point, Esc abandons",
        ),
        (glfw.KEY_ENTER, 0, "confirm", None, "Enter", "close the new cage; use it"),
        (glfw.KEY_KP_ENTER, 0, "confirm", None, None, None),
        (glfw.KEY_R, 0, "reset_target", None, "R", "reset the target to the source cage"),
        (glfw.KEY_B, 0, "fold_free", None, "B", "fold-free on or off: a warp proven never to fold (poisson)"),
        (
            glfw.KEY_F,
            0,
            "fit",
            None,
            "F",
            "fit the cage to the subject (on a photo: drag a rectangle around it first)",
        ),
        (glfw.KEY_S, 0, "subdivide", None, "S", "subdivide the cage (same curve, twice the points)"),
        (glfw.KEY_DELETE, 0, "delete", None, "Delete", "delete the selected points (cage) or pin (pins)"),
        (glfw.KEY_BACKSPACE, 0, "delete", None, None, None),
        (glfw.KEY_K, 0, "cycle_kernel", "next", "K, Shift+K", "next (previous) kernel"),
        (glfw.KEY_K, shift, "cycle_kernel", "previous", None, None),
        # The views, Shift+1, Shift+2, ... in the panel's order.
        *(
            (glfw.KEY_1 + k, shift, "view_mode", mode.name, f"Shift+{k + 1}", mode.help)
            for k, mode in enumerate(VIEW_MODES)
        ),
        (glfw.KEY_EQUAL, 0, "zoom", "in", "+, -", "zoom in, out (about the canvas centre)"),
        (glfw.KEY_EQUAL, shift, "zoom", "in", None, None),
        (glfw.KEY_KP_ADD, 0, "zoom", "in", None, None),
        (glfw.KEY_MINUS, 0, "zoom", "out", None, None),
        (glfw.KEY_KP_SUBTRACT, 0, "zoom", "out", None, None),
        (glfw.KEY_1, 0, "zoom", 1.0, "1, 2, 3", "zoom to 100 %, 200 %, 400 %"),
        (glfw.KEY_2, 0, "zoom", 2.0, None, None),
        (glfw.KEY_3, 0, "zoom", 4.0, None, None),
        (glfw.KEY_0, 0, "fit_view", None, "0, Home", "fit the image in the window"),
        (glfw.KEY_X, 0, "toggle", "show_folds", "X", "show folded-over triangles"),
        (glfw.KEY_W, 0, "toggle", "show_wireframe", "W", "show the mesh edges"),
        (glfw.KEY_V, 0, "toggle", "show_overlay", "V", "show the curves and handles"),
        (glfw.KEY_HOME, 0, "fit_view", None, None, None),
        (glfw.KEY_P, 0, "play", None, "P", "play or stop the demo script"),
        (
            glfw.KEY_SPACE,
            0,
            "playback",
            None,
            "Space",
            "play or pause the keyframes (the timeline in the panel)",
        ),
        (glfw.KEY_I, 0, "add_keyframe", None, "I", "a keyframe at the current time from the target shown"),
        (glfw.KEY_RIGHT, 0, "seek_by", 0.1, "Left, Right", "the time 1/10 s back or on (Shift: 1 s)"),
        (glfw.KEY_LEFT, 0, "seek_by", -0.1, None, None),
        (glfw.KEY_RIGHT, shift, "seek_by", 1.0, None, None),
        (glfw.KEY_LEFT, shift, "seek_by", -1.0, None, None),
        (glfw.KEY_F1, 0, "help", None, "F1, H", "this help"),
        (glfw.KEY_H, 0, "help", None, None, None),
    ]


MOUSE_HELP = [
    ("Wheel", "zoom around the cursor"),
    ("Middle or right drag", "pan"),
    ("Drag on empty canvas", "select the handles inside a rubber band (deform mode; Shift adds)"),
    ("Shift+click", "add a handle to the selection, or take it out; drag one to move them all"),
]
