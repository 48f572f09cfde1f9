#version 330 core
// The source image, stored with premultiplied alpha so that mipmaps, bilinear
// filtering, multisample resolve and blending all average colours correctly.

uniform sampler2D u_image;

in vec2 v_uv;
out vec4 f_colour;

void main() {
    f_colour = texture(u_image, v_uv);
}
