"""The interactive viewer: ``python -m app``, ``python -m app view`` and ``python -m app demo``.

Modules, each named by what it does:

- `state`: the immutable `Snapshot` of an edit, the undo `History`, the `AppState`;
- `editing`: pure geometry of the edits (picking, inserting, deleting, subdividing, zoom);
- `controller`: what mouse events and commands do to the state;
- `pin_tool`: pins in the picture, solved into the target (`core.pin_deform`);
- `precompute`: the basis functions in a background process, with progress;
- `scene`: keeps the renderer (`app.render.renderer.WarpRenderer`) in step with the state;
- `gui`: the imgui widgets; `window`: the glfw loop; `session`: opening and saving;
- `demos`: the bundled demo images, cages and scripts.
"""
