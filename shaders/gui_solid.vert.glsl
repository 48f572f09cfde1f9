#version 330 core
// imgui's own vertex shader (imgui_bundle's OpenGL backend), for its flat-coloured triangles:
// the same transform and the same interpolated colour, so the same pixels are covered.

uniform mat4 ProjMtx;
in vec2 Position;
in vec4 Color;
out vec4 Frag_Color;

void main() {
    Frag_Color = Color;
    gl_Position = ProjMtx * vec4(Position.xy, 0, 1);
}
