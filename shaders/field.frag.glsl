#version 330 core
// A scalar field coloured in bands of constant width (the paper's Fig. 1: bands
// [k, k + 1] / 10, negative values red, values above 1 green), with a thin dark
// line on every band edge so neighbouring bands of similar colour stay apart.
// Edges are blended over one pixel with fwidth, because multisampling only
// smooths the edges of triangles, not colour changes inside them.

const int BAND_COUNT = 12;

uniform vec3 u_bands[BAND_COUNT];  // colour of band k, covering [start + k width, start + (k + 1) width)
uniform float u_band_start;
uniform float u_band_width;

in float v_value;
out vec4 f_colour;

vec3 band(float k) {
    return u_bands[int(clamp(k, 0.0, float(BAND_COUNT - 1)))];
}

void main() {
    float f = (v_value - u_band_start) / u_band_width;
    float k = floor(f);
    float inside = f - k;
    float blur = max(fwidth(f), 1e-6);
    vec3 colour = band(k);
    colour = mix(colour, band(k + 1.0), clamp((inside - 1.0) / blur + 0.5, 0.0, 1.0));
    colour = mix(colour, band(k - 1.0), clamp(0.5 - inside / blur, 0.0, 1.0));
    float pixels_to_edge = min(inside, 1.0 - inside) / blur;
    colour *= mix(0.72, 1.0, clamp(pixels_to_edge - 0.25, 0.0, 1.0));
    f_colour = vec4(colour, 1.0);
}
