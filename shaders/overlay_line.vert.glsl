#version 330 core
// Overlay lines (curves, control polygons): image pixels to framebuffer pixels
// through the view; overlay_line.geom.glsl widens each segment there.

uniform float u_scale;
uniform vec2 u_offset;

in vec2 in_position;  // image pixels
in vec4 in_colour;    // straight alpha
in float in_size;     // line width in framebuffer pixels

out vec2 v_pixel;
out vec4 v_colour;
out float v_size;

void main() {
    v_pixel = u_offset + u_scale * in_position;
    v_colour = in_colour;
    v_size = in_size;
}
