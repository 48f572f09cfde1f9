#version 330 core
// Antialiased line coverage from the distance to the centre line; premultiplied output.

in vec4 g_colour;
in float g_across;
in float g_half_width;

out vec4 f_colour;

void main() {
    float coverage = clamp(g_half_width + 0.5 - abs(g_across), 0.0, 1.0);
    float alpha = g_colour.a * coverage;
    f_colour = vec4(g_colour.rgb * alpha, alpha);
}
