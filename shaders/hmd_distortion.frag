#version 310 es
// The HMD's lens correction: each colour channel samples the eye image at its own coordinate
// (the lens bends red, green and blue by different amounts); outside the image is black.
precision highp float;
uniform sampler2D eye_image;
in vec2 v_red_uv;
in vec2 v_green_uv;
in vec2 v_blue_uv;
out vec4 colour;

float channel(vec2 uv, int c) {
  if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) return 0.0;
  return texture(eye_image, uv)[c];
}

void main() {
  colour = vec4(channel(v_red_uv, 0), channel(v_green_uv, 1), channel(v_blue_uv, 2), 1.0);
}
