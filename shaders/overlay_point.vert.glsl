#version 330 core
// Overlay handles (control points) as point sprites of a given diameter in
// framebuffer pixels, centred on an image point mapped through the view.

uniform float u_scale;
uniform vec2 u_offset;
uniform vec2 u_viewport;

in vec2 in_position;  // image pixels
in vec4 in_colour;    // straight alpha
in float in_size;     // diameter in framebuffer pixels

out vec4 v_colour;
out float v_size;

void main() {
    vec2 pixel = u_offset + u_scale * in_position;
    gl_Position = vec4(2.0 * pixel.x / u_viewport.x - 1.0, 1.0 - 2.0 * pixel.y / u_viewport.y, 0.0, 1.0);
    gl_PointSize = in_size + 2.0;  // one pixel of antialiasing all around
    v_colour = in_colour;
    v_size = in_size;
}
