#version 310 es
// The building's depth pre-pass (compositor): the same positions as compose_building.vert
// (invariant, so that the colour pass's depth test with GL_LEQUAL passes exactly the nearest
// surface), and nothing else: every pixel is then shaded once, whatever the model's overdraw.
layout(location = 0) in highp vec3 position;   // site frame, metres

uniform highp mat4 clip_from_site;

invariant gl_Position;

void main() {
  gl_Position = clip_from_site * vec4(position, 1.0);
}
