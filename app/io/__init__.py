"""Files on disk: cages, sessions, images (read, checked, written), the bundled files."""
