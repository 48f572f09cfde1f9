"""The studies: Fig. 1's comparison, folds and distortion per kernel."""
