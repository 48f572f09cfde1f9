"""Where the viewer's window opens: a size that fits the monitor's work area, or the one it had last.

All rectangles are (x, y, width, height) in screen pixels, origin at the top-left
of the virtual screen, as glfw reports them (``glfw.get_monitor_workarea``).
"""

from __future__ import annotations

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
