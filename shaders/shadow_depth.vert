#version 310 es
// Shadow-map pass: the model seen from one sample direction through an orthographic projection
// (built on the CPU) that covers the bounding sphere of the scene. Depth only.
layout(location = 0) in highp vec3 position;

uniform highp mat4 clip_from_world;

void main() {
  gl_Position = clip_from_world * vec4(position, 1.0);
}
