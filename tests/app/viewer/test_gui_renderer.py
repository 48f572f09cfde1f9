"""app.viewer.gui_renderer: imgui drawn with flat runs through a fetch-free program, the same pixels.

The run splitting and the flat-triangle test are checked on arrays; the pixels on a real
window under Xvfb (Mesa llvmpipe), against imgui_bundle's own renderer drawing the same
frame over the same background.  Xvfb is required: without it the test fails, never skips.
"""

import json
import os
import subprocess
import sys

import numpy as np
from imgui_bundle import imgui
from support.paths import ROOT
from support.viewer_harness import start_xvfb

from app.viewer.gui_renderer import MIN_SOLID_PIXELS, flat_triangles, solid_runs


def test_solid_runs_cover_every_triangle_in_order_and_merge_small_flat_runs():
    rng = np.random.default_rng(5)
    for _ in range(50):
        count = int(rng.integers(1, 60))
        flat = rng.random(count) < 0.6
        areas = rng.choice([1.0, 10.0, MIN_SOLID_PIXELS, 5 * MIN_SOLID_PIXELS], size=count)
        runs = solid_runs(flat, areas)
        starts = [first for first, _, _ in runs]
        assert starts[0] == 0 and sum(length for _, length, _ in runs) == count
        assert all(a + n == b for (a, n, _), b in zip(runs, starts[1:], strict=False))
        for first, length, solid in runs:
            assert length > 0
            if solid:
                assert flat[first : first + length].all()
                assert areas[first : first + length].sum() >= MIN_SOLID_PIXELS
        assert not any(not a[2] and not b[2] for a, b in zip(runs, runs[1:], strict=False))
        # A maximal flat run large enough is drawn on its own.
        edges = np.flatnonzero(np.diff(np.r_[0, flat.astype(int), 0]))
        for start, end in zip(edges[::2], edges[1::2], strict=True):
            if areas[start:end].sum() >= MIN_SOLID_PIXELS:
                assert (int(start), int(end - start), True) in runs
    assert solid_runs(np.zeros(0, bool), np.zeros(0)) == []


def test_flat_triangles_reads_imgui_vertices():
    white = (0.5 / 512, 0.5 / 128)
    layout = np.zeros(4, dtype=[("position", "<f4", 2), ("uv", "<f4", 2), ("colour", "u1", 4)])
    assert layout.itemsize == imgui.VERTEX_SIZE
    layout["position"] = [[0, 0], [10, 0], [10, 20], [0, 20]]
    layout["uv"] = [white, white, white, [0.25, 0.5]]
    indices = np.array([0, 1, 2, 0, 2, 3, 2, 1, 0], np.uint16)
    flat, areas = flat_triangles(layout.tobytes(), indices, white)
    assert flat.tolist() == [True, False, True]
    np.testing.assert_allclose(areas, [100.0, 100.0, 100.0])


_CHILD = r"""
import json, sys
import glfw
import moderngl
import numpy as np
import OpenGL.GL as gl
from imgui_bundle import imgui
from imgui_bundle.python_backends.glfw_backend import GlfwRenderer

import app.viewer.gui_renderer as module

glfw.init()
glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 3)
glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 3)
glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
window = glfw.create_window(640, 480, "gui", None, None)
glfw.make_context_current(window)
ctx = moderngl.create_context()
imgui.create_context()
imgui.get_io().set_ini_filename("")
renderer = module.GuiRenderer(window, ctx)
solid = []
runs = module.solid_runs
module.solid_runs = lambda *a, **k: solid.append(sum(r[2] for r in runs(*a, **k))) or runs(*a, **k)

rng = np.random.default_rng(3)
background = ctx.program(
    vertex_shader="#version 330\nin vec2 p; in vec4 c; out vec4 v;\n"
    "void main() { v = c; gl_Position = vec4(p, 0, 1); }",
    fragment_shader="#version 330\nin vec4 v; out vec4 o; void main() { o = v; }",
)
data = np.hstack([rng.uniform(-1, 1, (300, 2)), rng.uniform(0, 1, (300, 4))]).astype("f4")
triangles = ctx.vertex_array(background, [(ctx.buffer(data.tobytes()), "2f 4f", "p", "c")])


def widgets():
    imgui.new_frame()
    imgui.set_next_window_pos((0, 0))
    imgui.set_next_window_size((300, 400))
    imgui.begin("panel")
    for i in range(8):
        imgui.button(f"button {i}")
        imgui.same_line()
        imgui.text(f"text {i} {'x' * i}")
    imgui.checkbox("check", True)
    imgui.slider_float("slider", 0.3, 0.0, 1.0)
    imgui.separator_text("separator")
    draw = imgui.get_window_draw_list()
    draw.add_rect_filled((20, 300), (280, 380), imgui.get_color_u32((0.2, 0.6, 0.3, 0.7)))
    imgui.end()
    imgui.set_next_window_pos((200, 150))
    imgui.set_next_window_size((380, 300))
    imgui.set_next_window_bg_alpha(0.55)
    imgui.begin("over")
    imgui.text_wrapped("A translucent window over the other and over the background. " * 4)
    imgui.end()
    imgui.render()
    return imgui.get_draw_data()


def pixels(render, draw_data):
    ctx.screen.use()
    ctx.disable(moderngl.BLEND)
    ctx.clear(0.13, 0.13, 0.14, 1.0)
    triangles.render()
    render(draw_data)
    buffer = gl.glReadPixels(0, 0, 640, 480, gl.GL_RGBA, gl.GL_UNSIGNED_BYTE)
    return np.frombuffer(buffer, np.uint8).reshape(480, 640, 4)


for _ in range(3):  # the font atlas is made and uploaded in the first frames
    renderer.render(widgets())
    glfw.swap_buffers(window)
draw_data = widgets()
plain = pixels(lambda d: None, draw_data)
solid.clear()
ours = pixels(renderer.render, draw_data)
used = sum(solid)
theirs = pixels(lambda d: GlfwRenderer.render(renderer, d), draw_data)
differ = int(np.count_nonzero(np.any(ours != theirs, axis=-1)))
drawn = int(np.count_nonzero(np.any(theirs != plain, axis=-1)))
print(json.dumps({"solid_runs": used, "different_pixels": differ, "gui_pixels": drawn}))
renderer.shutdown()
glfw.terminate()
"""


def test_the_gui_pixels_are_those_of_imgui_bundles_renderer():
    server, display = start_xvfb((640, 480))
    try:
        environment = dict(os.environ, DISPLAY=display, PYTHONPATH=str(ROOT))
        result = subprocess.run(
            [sys.executable, "-c", _CHILD], env=environment, capture_output=True, text=True, timeout=120
        )
    finally:
        server.terminate()
        server.wait(timeout=10)
    assert result.returncode == 0, result.stderr[-2000:]
    report = json.loads(result.stdout.strip().splitlines()[-1])
    assert report["gui_pixels"] > 100_000  # the widgets cover much of the window
    assert report["solid_runs"] >= 2  # window backgrounds drawn through the fetch-free program
    assert report["different_pixels"] == 0
