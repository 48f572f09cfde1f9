#version 330 core
// One colour for overlays (wireframe, folded triangles), premultiplied alpha.

uniform vec4 u_colour;

out vec4 f_colour;

void main() {
    f_colour = u_colour;
}
