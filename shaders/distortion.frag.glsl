#version 330 core
// The distortion view (app/viewer/distortion_view.py): a per-vertex value in log2
// units, for the area change log2 det J a diverging ramp (blue: shrunk, white:
// kept, red: grown), for the anisotropy log2(sigma1 / sigma2) a ramp from white
// (angles kept) to violet; full colour at u_range.  Thin isolines at every whole
// value (each halving or doubling), drawn with fwidth.  Values below -50 mark
// folded vertices (det J <= 0): painted in u_folded.  A second pass with
// u_folds_only draws only those, so that a fold stays visible where the
// unfolded part of the mesh lies over it.

uniform int u_measure;      // 0: area, 1: conformal
uniform float u_range;      // |value| of full colour
uniform vec3 u_shrunk;
uniform vec3 u_grown;
uniform vec3 u_sheared;
uniform vec3 u_folded;
uniform bool u_folds_only;

in float v_value;
out vec4 f_colour;

void main() {
    if (v_value < -50.0) {
        f_colour = vec4(u_folded, 1.0);
        return;
    }
    if (u_folds_only) {
        discard;
    }
    float t = clamp(v_value / u_range, -1.0, 1.0);
    vec3 colour;
    if (u_measure == 0) {
        colour = t < 0.0 ? mix(vec3(1.0), u_shrunk, -t) : mix(vec3(1.0), u_grown, t);
    } else {
        colour = mix(vec3(1.0), u_sheared, max(t, 0.0));
    }
    float blur = max(fwidth(v_value), 1e-6);
    float to_line = abs(v_value - floor(v_value + 0.5)) / blur;
    colour *= mix(0.75, 1.0, clamp(to_line - 0.25, 0.0, 1.0));
    f_colour = vec4(colour, 1.0);
}
