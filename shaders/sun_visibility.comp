#version 310 es
// The sun's visibility over a shadowing plane (render/sun_shadow_map.hpp): one invocation per
// plane texel, V = sun_visibility(texel centre) from the sun's shadow map, into an R32F image
// that the GPU blend reads as its sun term.
// library: sun_shadow.glsl
// The library decides lit and umbra texels from the map's minimum/maximum pyramid.
#define SUN_SHADOW_MINMAX 1
precision highp float;
precision highp int;
precision highp image2D;

layout(local_size_x = 8, local_size_y = 8) in;

uniform vec3 plane_origin;  // the plane's corner (texel (0, 0)'s outer corner), site frame
uniform vec3 plane_u;       // edge along the columns
uniform vec3 plane_v;       // edge along the rows
layout(r32f, binding = 0) writeonly uniform image2D visibility;

float sun_visibility(vec3 world_position);

void main() {
  ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
  ivec2 size = imageSize(visibility);
  if (texel.x >= size.x || texel.y >= size.y) return;
  // The texel centre, as geom::Plane::texel_centre.
  vec2 f = (vec2(texel) + 0.5) / vec2(size);
  vec3 centre = plane_origin + f.x * plane_u + f.y * plane_v;
  imageStore(visibility, texel, vec4(sun_visibility(centre), 0.0, 0.0, 1.0));
}
