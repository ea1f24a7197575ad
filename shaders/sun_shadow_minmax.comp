#version 310 es
// One level of the sun shadow map's minimum/maximum pyramid (render/sun_shadow_map.hpp): texel
// (i, j) of level k holds the least and the greatest depth of the map over the block of
// 8·2^k × 8·2^k map texels from 8·2^k·(i, j), from the 8 × 8 map texels of its block (level 0)
// or the 2 × 2 texels below it. Texels past the map's edge repeat the edge. The levels lie side
// by side in one texture (sun_shadow.glsl, "the pyramid's atlas"), so that a shader can pick a
// level per pixel with texelFetch at level 0. It lets sun_shadow.glsl decide "lit" or "in
// umbra" from four texels instead of its search and filter taps.
precision highp float;
precision highp int;
precision highp image2D;

layout(local_size_x = 8, local_size_y = 8) in;

uniform highp sampler2D depth_map;   // DEPTH_COMPONENT32F
uniform highp sampler2D atlas;       // the pyramid so far
uniform bool from_depth;             // level 0: from depth_map; else from the level below
uniform ivec2 source_origin;         // the level below in the atlas
uniform ivec2 target_origin;         // this level in the atlas
uniform int target_size;             // this level's side, texels
layout(rgba32f, binding = 0) writeonly uniform image2D target;

void main() {
  ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
  if (texel.x >= target_size || texel.y >= target_size) return;
  ivec2 last = textureSize(depth_map, 0) - 1;
  vec2 range = vec2(1.0e30, -1.0e30);
  // A loop as long as its source (64 map texels or 4 texels of the level below), so that the
  // upper levels do not pay for the first's reads.
  int count = from_depth ? 64 : 4;
  for (int k = 0; k < count; ++k) {
    if (from_depth) {
      float d = texelFetch(depth_map, min(8 * texel + ivec2(k & 7, k >> 3), last), 0).r;
      range = vec2(min(range.x, d), max(range.y, d));
    } else {
      vec2 m = texelFetch(atlas, source_origin + 2 * texel + ivec2(k & 1, k >> 1), 0).rg;
      range = vec2(min(range.x, m.x), max(range.y, m.y));
    }
  }
  imageStore(target, target_origin + texel, vec4(range, 0.0, 0.0));
}
