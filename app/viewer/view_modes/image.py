"""The warped image: the default view."""

from app.viewer.view_modes.mode import ViewMode

MODE = ViewMode("image", "Warped image", "show the warped image", "image")
