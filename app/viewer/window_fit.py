"""Where the viewer's window opens: a size that fits the monitor's work area, or the one it had last
(`screen_rectangle`, with `save_settings` when it closes).

All rectangles are (x, y, width, height) in screen pixels, origin at the top-left
of the virtual screen, as glfw reports them (``glfw.get_monitor_workarea``).
"""

from __future__ import annotations

import sys

#: Fraction of the work area (the screen without panels and docks) a first window takes.
WORK_AREA_FRACTION = 0.9
#: The smallest window a saved or asked size is taken to (a panel and some canvas beside it).
SMALLEST = (400, 300)


def opening_rectangle(
    work_area: tuple[int, int, int, int],
    saved: tuple[int, int, int, int] | None = None,
    asked: tuple[int, int] | None = None,
) -> tuple[int, int, int, int]:
    """The window's (x, y, width, height) when the viewer opens.

    Parameters
    ----------
    work_area : (x, y, width, height)
        The monitor's work area.
    saved : (x, y, width, height), optional
        Where the window was when the last viewer closed (`app.viewer.settings`).
    asked : (width, height), optional
        A size asked for on the command line (``--window-size``): it wins over `saved`.

    Returns
    -------
    (x, y, width, height)
        Never larger than the work area and inside it; `asked` or `saved` if they fit, a
        saved position moved (not shrunk) back onto the work area when its monitor is gone,
        else ``WORK_AREA_FRACTION`` of the work area, centred.
    """
    left, top, area_width, area_height = work_area
    if asked is not None:
        width, height = asked
        x, y = left + (area_width - width) // 2, top + (area_height - height) // 2
    elif saved is not None:
        x, y, width, height = saved
    else:
        width = round(WORK_AREA_FRACTION * area_width)
        height = round(WORK_AREA_FRACTION * area_height)
        x, y = left + (area_width - width) // 2, top + (area_height - height) // 2
    width = min(max(width, min(SMALLEST[0], area_width)), area_width)
    height = min(max(height, min(SMALLEST[1], area_height)), area_height)
    x = min(max(x, left), left + area_width - width)
    y = min(max(y, top), top + area_height - height)
    return int(x), int(y), int(width), int(height)


def monitor_work_area(
    areas: list[tuple[int, int, int, int]], saved: tuple[int, int, int, int] | None
) -> tuple[int, int, int, int]:
    """The work area, of `areas` (the primary monitor's first), holding the centre of the `saved`
    window; the primary one if none holds it (its monitor was unplugged) or nothing was saved."""
    if saved is not None:
        x, y, width, height = saved
        centre = (x + width / 2, y + height / 2)
        for area in areas:
            left, top, area_width, area_height = area
            if left <= centre[0] < left + area_width and top <= centre[1] < top + area_height:
                return area
    return areas[0]


def screen_rectangle(
    glfw, state, asked: tuple[int, int] | None, default: tuple[int, int]
) -> tuple[int, int, int, int]:
    """(x, y, width, height) of the window: `asked` for, as last closed, or fitted to the screen.

    The settings' way of drawing cages becomes `state.selection.cage_drawing` (an
    `app.viewer.state.AppState`); `glfw` is the module (its monitors); `default` the size
    without any monitor reported.
    """
    from app.viewer.drawing import STYLES
    from app.viewer.settings import read_settings, window_rectangle

    settings = read_settings()
    if settings.get("cage_drawing") in STYLES:
        state.selection.cage_drawing = settings["cage_drawing"]
    saved = window_rectangle(settings)
    monitors = [glfw.get_primary_monitor()] + [m for m in glfw.get_monitors() or [] if m]
    areas = [tuple(glfw.get_monitor_workarea(m)) for m in monitors if m]
    if not areas:  # no monitor reported: the size asked for, or the old default
        return (0, 0, *(asked or default))
    return opening_rectangle(monitor_work_area(areas, saved), saved, asked)


def save_settings(glfw, window, state) -> None:
    """Remember `window`'s place and size, and how cages are drawn, for the next viewer."""
    from app.io.files import InputError
    from app.viewer.settings import write_settings

    x, y = glfw.get_window_pos(window)
    width, height = glfw.get_window_size(window)
    rectangle = {"x": x, "y": y, "width": width, "height": height}
    try:
        write_settings({"window": rectangle, "cage_drawing": state.selection.cage_drawing})
    except (InputError, OSError) as error:
        print(f"note: cannot save the viewer's settings: {error}", file=sys.stderr)
