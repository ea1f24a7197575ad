#version 310 es
// Visibility pass over mesh vertices: vertex i of the draw becomes the pixel (i mod W, i / W) of
// a W×H target, so that reading the target back row by row gives one value per vertex in order.
layout(location = 0) in highp vec3 position;
layout(location = 1) in highp vec3 normal;

uniform highp ivec2 target_size;
uniform highp float surface_offset;  // the nudge off the surface, along the normal (metres)

out highp vec3 sample_position;
flat out highp vec3 sample_normal;

void main() {
  ivec2 texel = ivec2(gl_VertexID % target_size.x, gl_VertexID / target_size.x);
  gl_Position = vec4((vec2(texel) + 0.5) / vec2(target_size) * 2.0 - 1.0, 0.0, 1.0);
  gl_PointSize = 1.0;
  sample_position = position + surface_offset * normal;
  sample_normal = normal;
}
