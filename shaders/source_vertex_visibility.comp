#version 310 es
// A separated source's visibility at the model's vertices (render/sun_shadow_map.hpp): one
// invocation per vertex, V = sun_visibility(position moved along its normal) from the source's
// shadow map, into value first_value + vertex of a buffer (one block of vertices per source):
// the building's light from a lamp, added per vertex by the compositor.
// library: sun_shadow.glsl
// The library decides lit and umbra vertices from the map's minimum/maximum pyramid.
#define SUN_SHADOW_MINMAX 1
precision highp float;
precision highp int;

layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Positions {
  float position[];  // x, y, z per vertex, site frame
};
layout(std430, binding = 1) readonly buffer Normals {
  float normal[];    // x, y, z per vertex, unit
};
layout(std430, binding = 2) writeonly buffer Visibility {
  float visibility[];
};

uniform int vertex_count;
uniform int first_value;      // source k's block: k · vertex_count
uniform float normal_offset;  // metres along the normal, off the surface the vertex lies on

float sun_visibility(vec3 world_position);

void main() {
  int v = int(gl_GlobalInvocationID.x);
  if (v >= vertex_count) return;
  vec3 p = vec3(position[3 * v], position[3 * v + 1], position[3 * v + 2]);
  vec3 n = vec3(normal[3 * v], normal[3 * v + 1], normal[3 * v + 2]);
  visibility[first_value + v] = sun_visibility(p + normal_offset * n);
}
