#version 330 core
// A line segment as a screen-space quad of the requested width plus one pixel of
// antialiasing on each side, extended by half the width at both ends so that the
// segments of a polyline meet without gaps.  (Core-profile GL has no wide lines.)

layout(lines) in;
layout(triangle_strip, max_vertices = 4) out;

uniform vec2 u_viewport;

in vec2 v_pixel[];
in vec4 v_colour[];
in float v_size[];

out vec4 g_colour;
out float g_across;     // signed pixels from the centre line
out float g_half_width;

vec4 clip(vec2 pixel) {
    return vec4(2.0 * pixel.x / u_viewport.x - 1.0, 1.0 - 2.0 * pixel.y / u_viewport.y, 0.0, 1.0);
}

void main() {
    vec2 a = v_pixel[0], b = v_pixel[1];
    vec2 along = b - a;
    float length_ = length(along);
    along = length_ > 1e-6 ? along / length_ : vec2(1.0, 0.0);
    vec2 normal = vec2(-along.y, along.x);
    for (int end = 0; end < 2; ++end) {
        float half_width = 0.5 * v_size[end];
        float reach = half_width + 1.0;
        vec2 centre = (end == 0 ? a - along * half_width : b + along * half_width);
        for (int side = -1; side <= 1; side += 2) {
            g_colour = v_colour[end];
            g_half_width = half_width;
            g_across = float(side) * reach;
            gl_Position = clip(centre + normal * float(side) * reach);
            EmitVertex();
        }
    }
    EndPrimitive();
}
