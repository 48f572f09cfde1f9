#version 330 core
// One basis function G_i as a heat map (the paper's Fig. 8): a continuous ramp
// over [0, 1], values below 0 (mean value coordinates on non-convex domains) in
// a colour of their own, thin isolines every 0.1 and a bold one at 0, drawn with
// fwidth so that they stay one pixel wide at any zoom.

const int STOP_COUNT = 5;

uniform vec3 u_stops[STOP_COUNT];  // ramp colours at 0, 1/4, 1/2, 3/4 and 1
uniform vec3 u_negative;           // colour of values below 0

in float v_value;
out vec4 f_colour;

vec3 ramp(float value) {
    float f = clamp(value, 0.0, 1.0) * float(STOP_COUNT - 1);
    int k = int(min(floor(f), float(STOP_COUNT - 2)));
    return mix(u_stops[k], u_stops[k + 1], f - float(k));
}

void main() {
    vec3 colour = v_value < 0.0 ? u_negative * (1.0 + clamp(v_value * 5.0, -0.6, 0.0)) : ramp(v_value);
    float f = v_value * 10.0;
    float blur = max(fwidth(f), 1e-6);
    float to_line = abs(f - floor(f + 0.5)) / blur;
    colour *= mix(0.7, 1.0, clamp(to_line - 0.25, 0.0, 1.0));
    float to_zero = abs(v_value) / max(fwidth(v_value), 1e-9);
    colour = mix(vec3(1.0), colour, clamp(to_zero - 0.75, 0.0, 1.0));
    f_colour = vec4(colour, 1.0);
}
