"""``python -m app`` and the console script ``transfinite-warp``: the command line of `app.commands.cli`.

Under an address-space limit too small to load the program's libraries (which
then spin or crash instead of failing), it stops first, in one line, with exit
code 1 (`app.render.address_space`).
"""

import sys

from app.render.address_space import startup_problem


def main(argv: list[str] | None = None) -> int:
    """Run `app.commands.cli.main` on `argv` (``sys.argv[1:]`` by default); returns the exit code."""
    problem = startup_problem()
    if problem is not None:
        print(f"error: {problem}", file=sys.stderr)
        return 1
    from app.commands.cli import main as run

    return run(argv)


if __name__ == "__main__":
    sys.exit(main())
