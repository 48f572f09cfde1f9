"""One warp job and the pipeline under it: framing, fill, keyframes, frames, reports."""
