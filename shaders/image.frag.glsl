#version 330 core
// The source image, stored with premultiplied alpha so that mipmaps, bilinear
// filtering, multisample resolve and blending all average colours correctly.
// u_opacity fades the whole image (1 for the warp, less for the viewer's backdrop).
// u_snap (drawings at one output pixel per image pixel): a texture coordinate within float32's
// rounding of a texel's centre reads that texel itself, so that an undeformed part of the
// picture comes back exactly rather than blended with its neighbours by the rounding.
// u_coverage: instead of the picture, how much of the pixel it covers (in every channel), as the
// alpha of an opaque picture drawn the same way: 1 inside the image, fading to 0 over the half
// texel past its edge as bilinear filtering against the transparent border does (level 0), so that
// a translucent picture's own alpha and the warp's coverage are told apart when it is laid over
// the untouched picture.
// u_boxed: the texture holds only the part u_region (left, top, width, height, in pixels) of an
// image of u_image_size pixels (a drawing that samples no more of it); v_uv stays the whole image's.

uniform sampler2D u_image;
uniform float u_opacity;
uniform bool u_snap;
uniform bool u_coverage;
uniform bool u_boxed;
uniform vec2 u_image_size;
uniform vec4 u_region;

in vec2 v_uv;
out vec4 f_colour;

void main() {
    if (u_coverage) {
        vec2 size = u_image_size;
        vec2 texel = v_uv * size;
        vec2 inside = clamp(texel + 0.5, 0.0, 1.0) * clamp(size + 0.5 - texel, 0.0, 1.0);
        f_colour = vec4(inside.x * inside.y);
        return;
    }
    // In the texture: the image's pixel less the region's corner (exact: both are multiples of the
    // product's last place), over the region's size.
    vec2 uv = u_boxed ? (v_uv * u_image_size - u_region.xy) / u_region.zw : v_uv;
    vec4 colour;
    if (u_snap) {
        vec2 size = vec2(textureSize(u_image, 0));
        vec2 texel = uv * size - 0.5;
        vec2 nearest = floor(texel + 0.5);
        // Eight units in the last place of the image's larger side: the rounding of v_uv's
        // interpolation.
        float rounding = 8.0 * max(u_image_size.x, u_image_size.y) / 16777216.0;
        bool inside = all(greaterThanEqual(nearest, vec2(0.0))) && all(lessThan(nearest, size));
        if (inside && all(lessThanEqual(abs(texel - nearest), vec2(rounding)))) {
            colour = texelFetch(u_image, ivec2(nearest), 0);
        } else {
            colour = texture(u_image, uv);
        }
    } else {
        colour = texture(u_image, uv);
    }
    f_colour = colour * u_opacity;
}
