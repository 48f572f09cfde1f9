#version 330 core
// Keeps only the triangles that the deformation folds over or collapses, like
// core.folded_triangles: the deformed signed area (from clip space, whose y axis
// mesh.vert flipped) has not the sign of the undeformed one (from the texture
// coordinates, which are the undeformed vertices divided by the image size).
// Done on the GPU so that showing folds costs no CPU time per drag.

layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;

in vec2 v_uv[];

float cross2(vec2 a, vec2 b) {
    return a.x * b.y - a.y * b.x;
}

void main() {
    // Undeformed signed area in image-pixel orientation (uv = vertex / size).
    float source = cross2(v_uv[1] - v_uv[0], v_uv[2] - v_uv[0]);
    // Deformed signed area, back in image-pixel orientation: clip y = -pixel y.
    vec2 a = gl_in[0].gl_Position.xy, b = gl_in[1].gl_Position.xy, c = gl_in[2].gl_Position.xy;
    float deformed = -cross2(b - a, c - a);
    if (deformed * sign(source) > 0.0) {
        return;
    }
    for (int i = 0; i < 3; ++i) {
        gl_Position = gl_in[i].gl_Position;
        EmitVertex();
    }
    EndPrimitive();
}
