#version 330 core
// The source image, stored with premultiplied alpha so that mipmaps, bilinear
// filtering, multisample resolve and blending all average colours correctly.
// u_opacity fades the whole image (1 for the warp, less for the viewer's backdrop).

uniform sampler2D u_image;
uniform float u_opacity;

in vec2 v_uv;
out vec4 f_colour;

void main() {
    f_colour = texture(u_image, v_uv) * u_opacity;
}
