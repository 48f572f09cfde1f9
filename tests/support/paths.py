"""Where the repository is, for tests that read its files or run its commands."""

from pathlib import Path

#: The repository's root folder (tests/support/paths.py is two levels below it).
ROOT = Path(__file__).resolve().parents[2]
