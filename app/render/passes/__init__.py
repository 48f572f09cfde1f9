"""The drawing passes that `app.render.renderer.WarpRenderer` composes, each owning its GL programs.

- `image`: the mesh textured with the source image, and the marks on a mesh (folded
  triangles, chosen triangles, edges);
- `fields`: the mesh coloured by its per-vertex field (height bands, heat map, distortion);
- `backdrop`: the whole undeformed source image, faded, under the warp;
- `overlay`: antialiased lines and round handles on top;

and what they share: `mesh_buffers` (one mesh's buffers and vertex arrays), `source_image`
(the texture), `fold_possible` (whether the fold pass could mark anything) and `gl_state` (the
view's uniforms, the blending).
"""
