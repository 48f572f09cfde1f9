#version 330 core
// imgui's vertex shader (imgui_bundle's OpenGL backend): window pixels to clip space through
// ProjMtx, the texture coordinates and the vertex colour passed on.

uniform mat4 ProjMtx;
in vec2 Position;
in vec2 UV;
in vec4 Color;
out vec2 Frag_UV;
out vec4 Frag_Color;

void main() {
    Frag_UV = UV;
    Frag_Color = Color;
    gl_Position = ProjMtx * vec4(Position.xy, 0, 1);
}
