"""Colours written on the command line (``--background``): names, ``#rgb``, ``#rrggbb[aa]``, ``r,g,b[,a]``."""

from __future__ import annotations

#: The colour names understood, as 8-bit RGB.
NAMED_COLOURS = {
    "black": (0, 0, 0),
    "white": (255, 255, 255),
    "grey": (128, 128, 128),
    "gray": (128, 128, 128),
    "red": (255, 0, 0),
    "green": (0, 128, 0),
    "blue": (0, 0, 255),
}


def parse_colour(text: str) -> tuple[float, float, float, float]:
    """Straight RGBA in [0, 1] of a colour written as a name, ``#rgb``, ``#rrggbb``, ``#rrggbbaa``
    or ``r,g,b`` / ``r,g,b,a`` with components 0-255.

    Raises
    ------
    ValueError
        Anything else, with the forms that are understood.
    """
    written = text.strip().lower()
    values: list[int] | None = None
    if written in NAMED_COLOURS:
        values = list(NAMED_COLOURS[written])
    elif written.startswith("#") and len(written) in (4, 7, 9):
        digits = written[1:]
        if len(digits) == 3:
            digits = "".join(2 * digit for digit in digits)
        try:
            values = [int(digits[start : start + 2], 16) for start in range(0, len(digits), 2)]
        except ValueError:
            values = None
    elif "," in written:
        try:
            values = [int(part) for part in written.split(",")]
        except ValueError:
            values = None
        if values is not None and (len(values) not in (3, 4) or not all(0 <= v <= 255 for v in values)):
            values = None
    if values is None:
        raise ValueError(
            f"{text!r} is not a colour; write a name ({', '.join(NAMED_COLOURS)}), #rrggbb, #rrggbbaa "
            "or r,g,b"
        )
    if len(values) == 3:
        values.append(255)
    red, green, blue, alpha = (value / 255 for value in values)
    return red, green, blue, alpha
