"""The drawing passes that `app.render.WarpRenderer` composes, each owning its GL programs.

- `backdrop`: the whole undeformed source image, faded, under the warp;
- `overlay`: antialiased lines and round handles on top;

and what they share: `source_image` (the texture) and `gl_state` (the view's uniforms, the
blending).
"""
