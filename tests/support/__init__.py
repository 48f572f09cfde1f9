"""Helpers the tests share: example shapes and points, PNG files made in memory, fold checks,
the viewer-window harness.  Imported as `support.<module>` (tests/ is on the path through its
conftest)."""
