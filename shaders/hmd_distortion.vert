#version 310 es
// The HMD's lens correction: one vertex of an eye's distortion mesh, at its panel position
// (pixels, y from the top: framebuffer row 0 is the panel's top row, as the panel texture keeps
// it), with the eye image's texture coordinate for each colour channel.
layout(location = 0) in vec2 panel_position;
layout(location = 1) in vec2 red_uv;
layout(location = 2) in vec2 green_uv;
layout(location = 3) in vec2 blue_uv;
uniform vec2 panel_size;
out vec2 v_red_uv;
out vec2 v_green_uv;
out vec2 v_blue_uv;
void main() {
  v_red_uv = red_uv;
  v_green_uv = green_uv;
  v_blue_uv = blue_uv;
  gl_Position = vec4(panel_position / panel_size * 2.0 - 1.0, 0.0, 1.0);
}
