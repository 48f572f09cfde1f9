#version 330 core
// imgui's fragment shader (imgui_bundle's OpenGL backend): the vertex colour times the texture
// (the font atlas for text and for everything flat, an image for an image widget).

uniform sampler2D Texture;
in vec2 Frag_UV;
in vec4 Frag_Color;
out vec4 Out_Color;

void main() {
    Out_Color = Frag_Color * texture(Texture, Frag_UV.st);
}
