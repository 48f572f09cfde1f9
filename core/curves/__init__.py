"""Closed curves: quadratic B-splines (Sec. 4.1), sampled boundaries, arc length, distances, inside tests."""
