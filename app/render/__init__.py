"""GL rendering: the warp renderer, its passes, shaders, the view and memory checks."""
