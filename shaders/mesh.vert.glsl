#version 330 core
// Shared by every mesh program: maps image pixels (x right, y down, origin at the
// image's top-left corner) to clip space through the view transform of the
// session file, so that an image point (x, y) lands on framebuffer pixel
// (u_offset + u_scale * (x, y)) counted from the framebuffer's top-left corner.

uniform float u_scale;
uniform vec2 u_offset;
uniform vec2 u_viewport;  // framebuffer size in pixels

in vec2 in_position;  // deformed vertex, image pixels
in vec2 in_uv;        // undeformed vertex / image size (image programs only)
in float in_value;    // scalar field value (field program only)

out vec2 v_uv;
out float v_value;

void main() {
    vec2 pixel = u_offset + u_scale * in_position;
    // Window y grows downwards, clip y upwards.
    vec2 clip = vec2(2.0 * pixel.x / u_viewport.x - 1.0, 1.0 - 2.0 * pixel.y / u_viewport.y);
    gl_Position = vec4(clip, 0.0, 1.0);
    v_uv = in_uv;
    v_value = in_value;
}
