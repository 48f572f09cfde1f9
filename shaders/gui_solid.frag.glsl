#version 330 core
// imgui's fragment shader without its texture fetch: on a triangle whose texture coordinates
// are all the font atlas's white texel, at that texel's centre, the fetch returns exactly
// (1, 1, 1, 1), and Frag_Color * 1.0 is Frag_Color.  A software rasteriser spends most of
// imgui's fill on that bilinear fetch (the panel's background, frames and buttons).

in vec4 Frag_Color;
out vec4 Out_Color;

void main() {
    Out_Color = Frag_Color;
}
