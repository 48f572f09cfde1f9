#version 330 core
// A round handle: the fill colour inside a dark ring, antialiased; premultiplied output.

const vec3 RING = vec3(0.05, 0.05, 0.05);

in vec4 v_colour;
in float v_size;

out vec4 f_colour;

void main() {
    float radius = 0.5 * v_size;
    float distance_ = length(gl_PointCoord - 0.5) * (v_size + 2.0);
    float coverage = clamp(radius + 0.5 - distance_, 0.0, 1.0);
    float ring = clamp(distance_ - (radius - 1.75), 0.0, 1.0);
    vec3 colour = mix(v_colour.rgb, RING, ring * 0.85);
    float alpha = v_colour.a * coverage;
    f_colour = vec4(colour * alpha, alpha);
}
