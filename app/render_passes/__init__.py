"""The drawing passes that `app.render.WarpRenderer` composes, each owning its GL programs.

- `overlay`: antialiased lines and round handles on top;

and what they share: `gl_state` (the view's uniforms, the blending).
"""
