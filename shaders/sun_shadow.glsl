// Shader library (no #version; see gpu::read_shader): the sun's shadow map (render/
// sun_shadow_map.hpp), sampled with a penumbra that follows the sun's size.
//
//   float sun_visibility(vec3 world_position)   visible fraction of the sun's disc, 0 … 1
//   float sun_visibility_if(vec3 world_position, bool needed)   the same where needed, else 1
//
// A shader that uses it adds the line "// library: sun_shadow.glsl", declares the function it
// calls (e.g. "float sun_visibility(vec3 world_position);") before calling it, and a default
// float precision (precision highp float); SunShadowMap::bind sets the uniforms below. Usable
// from compute and fragment shaders. A shader that defines SUN_SHADOW_MINMAX (before this
// library) also reads the map's minimum/maximum pyramid and is bound with
// SunShadowMap::bind(program, unit, minmax_unit).
//
// Method (percentage-closer soft shadows): the map holds, per texel, the depth along the sun's
// direction of the nearest surface (orthographic, so depth is linear in metres). A blocker
// search around the point finds the mean depth of what lies between it and the sun; the
// distance d to that occluder sets the penumbra, whose half-width is d·tan(angular radius);
// then depth comparisons over a disc of that radius, each interpolated between its four nearest
// texels, average to the visible fraction. At least half a texel is filtered, so a sun of no
// size still gets an anti-aliased edge. The search covers the widest penumbra anything nearer
// the sun could cast (narrowed by the pyramid to what its nearest surface there could cast);
// both grids take as many taps as their radius needs (search taps under 1.5 texels apart,
// filter taps at most one), up to 6 × 6 and 8 × 8.
//
// Speed: a SIMD renderer (llvmpipe) runs both sides of every branch for a group of pixels, and a
// loop as long as its longest lane. The taps therefore run in loops whose trip count is 1 where
// the answer is known without them (not needed, outside the map, or decided by the pyramid:
// nothing nearer the sun in reach, lit; everything nearer, umbra; exactly what the taps would
// find), so that groups of such pixels skip them. The pyramid's levels lie side by side in one
// texture read at its level 0: a texelFetch level that differs between the pixels of a group is
// not honoured per pixel by llvmpipe (Mesa 22.3: wrong pyramid texels, tested), an atlas is.

uniform highp sampler2D sun_shadow_depth;    // DEPTH_COMPONENT32F, raw depth (compare mode NONE)
uniform highp mat4 sun_shadow_from_world;    // world → (s, t, depth), each in [0, 1] in the map
uniform highp vec4 sun_shadow_params;        // texel size (m), depth range (m), tan(angular radius), bias (m)
uniform highp vec3 sun_shadow_direction;     // unit, towards the sun
#ifdef SUN_SHADOW_MINMAX
// The pyramid's atlas: level k holds (min, max) of the map's depth over blocks of 8·2^k × 8·2^k
// texels, block (i, j) starting at texel 8·2^k·(i, j) (texels past the map's edge repeat the
// edge). With P its height (level 0's side), level 0 lies at (0, 0) and level k ≥ 1 at
// (P, P − P/2^(k−1)).
uniform highp sampler2D sun_shadow_minmax;   // RGBA32F; bound by SunShadowMap::bind
#endif

const int kSunBlockerTaps = 6;               // most taps per side of the blocker search grid
const int kSunFilterTaps = 8;                // most taps per side of the filter grid (taps inside its disc)
const highp float kSunMaxRadius = 32.0;      // texels: wider penumbrae are filtered at this radius

// 1 where the map's surface at texel t lies at or beyond `depth` (nothing nearer the sun).
highp float sun_shadow_lit(highp ivec2 t, highp float depth) {
  highp ivec2 last = textureSize(sun_shadow_depth, 0) - 1;
  return texelFetch(sun_shadow_depth, clamp(t, ivec2(0), last), 0).r >= depth ? 1.0 : 0.0;
}

// The comparison at a point between texel centres (x in texels, centres at i + 0.5),
// interpolated bilinearly between the four nearest texels' answers.
highp float sun_shadow_lit_bilinear(highp vec2 x, highp float depth) {
  highp vec2 p = x - 0.5;
  highp vec2 base = floor(p);
  highp vec2 f = p - base;
  highp ivec2 b = ivec2(base);
  highp float l00 = sun_shadow_lit(b, depth);
  highp float l10 = sun_shadow_lit(b + ivec2(1, 0), depth);
  highp float l01 = sun_shadow_lit(b + ivec2(0, 1), depth);
  highp float l11 = sun_shadow_lit(b + ivec2(1, 1), depth);
  return mix(mix(l00, l10, f.x), mix(l01, l11, f.x), f.y);
}

// The visible fraction where `needed`, 1 elsewhere (at the cost of a decided point: see Speed).
highp float sun_visibility_if(highp vec3 world_position, bool needed) {
  highp float texel_m = sun_shadow_params.x;
  highp float depth_m = sun_shadow_params.y;
  highp float tan_radius = sun_shadow_params.z;
  // The bias moves the point towards the sun, so that its own surface does not shadow it.
  highp vec4 q = sun_shadow_from_world * vec4(world_position + sun_shadow_params.w * sun_shadow_direction, 1.0);
  // Outside the map (which covers the whole site) or nearer the sun than all of it: lit.
  bool inside = needed && q.x >= 0.0 && q.x <= 1.0 && q.y >= 0.0 && q.y <= 1.0 && q.z > 0.0;
  highp float depth = min(q.z, 1.0);
  highp ivec2 size = textureSize(sun_shadow_depth, 0);
  highp vec2 x = q.xy * vec2(size);
  // The widest penumbra anything between the point and the sun could cast.
  highp float search = clamp(depth * depth_m * tan_radius / texel_m, 1.0, kSunMaxRadius);

  // Answers known from the texels that the search and the filter below can read (the filter's
  // radius never exceeds the search's): nothing there nearer the sun than the point, lit;
  // everything, in umbra. Exactly what the taps would find.
  highp float known = 1.0;
  bool decided = !inside;
  highp float reach = search;
#ifdef SUN_SHADOW_MINMAX
  {
    highp ivec2 lo = clamp(ivec2(floor(x - search - 2.0)), ivec2(0), size - 1);
    highp ivec2 hi = clamp(ivec2(floor(x + search + 1.0)), ivec2(0), size - 1);
    // The finest level whose blocks span the region in at most two per axis.
    highp int width = max(hi.x - lo.x, hi.y - lo.y) + 1;
    highp int level = 0;
    while ((8 << level) < width) ++level;
    highp int base = textureSize(sun_shadow_minmax, 0).y;
    highp ivec2 origin = level == 0 ? ivec2(0) : ivec2(base, base - (base >> (level - 1)));
    highp ivec2 last = ivec2(max((base >> level) - 1, 0));
    highp ivec2 a = origin + min(lo >> (level + 3), last);
    highp ivec2 b = origin + min(hi >> (level + 3), last);
    highp vec2 m0 = texelFetch(sun_shadow_minmax, a, 0).rg;
    highp vec2 m1 = texelFetch(sun_shadow_minmax, ivec2(b.x, a.y), 0).rg;
    highp vec2 m2 = texelFetch(sun_shadow_minmax, ivec2(a.x, b.y), 0).rg;
    highp vec2 m3 = texelFetch(sun_shadow_minmax, b, 0).rg;
    highp float nearest = min(min(m0.x, m1.x), min(m2.x, m3.x));
    highp float farthest = max(max(m0.y, m1.y), max(m2.y, m3.y));
    // Nothing nearer the sun than `nearest` can shade the point from farther than this.
    reach = clamp((depth - nearest) * depth_m * tan_radius / texel_m, 1.0, search);
    if (!decided && nearest >= depth) decided = true;
    if (!decided && farthest < depth) {
      decided = true;
      known = 0.0;
    }
  }
#endif

  // Blocker search within reach: the mean depth of what lies between the point and the sun.
  highp float blockers = 0.0;
  highp float blocker_depth = 0.0;
  // Taps per side: less than 1.5 texels apart (as 6 over the widest search), at least 3.
  int search_side = clamp(int(ceil(reach * 4.0 / 3.0)) + 1, 3, kSunBlockerTaps);
  int search_taps = decided ? 1 : search_side * search_side;
  // Grid position (i, j) of tap k, counted without divisions (slow per lane on a SIMD CPU).
  int k = 0;
  ivec2 ij = ivec2(0);
  do {
    highp vec2 o = (vec2(ij) + 0.5) / float(search_side) * 2.0 - 1.0;
    highp ivec2 t = clamp(ivec2(floor(x + o * reach)), ivec2(0), size - 1);
    highp float d = texelFetch(sun_shadow_depth, t, 0).r;
    if (d < depth) {
      blockers += 1.0;
      blocker_depth += d;
    }
    ++k;
    ij = ij.y + 1 < search_side ? ivec2(ij.x, ij.y + 1) : ivec2(ij.x + 1, 0);
  } while (k < search_taps);
  if (!decided && blockers == 0.0) decided = true;

  // The penumbra's half-width at the occluders' mean distance, in texels; depth comparisons over
  // a disc of that radius.
  highp float distance_m = (depth - blocker_depth / max(blockers, 1.0)) * depth_m;
  highp float radius = clamp(distance_m * tan_radius / texel_m, 0.5, kSunMaxRadius);
  highp float lit = 0.0;
  highp float taps = 0.0;
  // Taps per side: spaced at most a texel apart (finer gains nothing on the bilinear
  // comparisons), at least 2, at most kSunFilterTaps.
  int side = clamp(int(ceil(2.0 * radius)) + 1, 2, kSunFilterTaps);
  int filter_taps = decided ? 1 : side * side;
  k = 0;
  ij = ivec2(0);
  do {
    highp vec2 o = (vec2(ij) + 0.5) / float(side) * 2.0 - 1.0;
    if (dot(o, o) <= 1.0) {
      lit += sun_shadow_lit_bilinear(x + o * radius, depth);
      taps += 1.0;
    }
    ++k;
    ij = ij.y + 1 < side ? ivec2(ij.x, ij.y + 1) : ivec2(ij.x + 1, 0);
  } while (k < filter_taps);
  return decided ? known : lit / taps;
}

highp float sun_visibility(highp vec3 world_position) { return sun_visibility_if(world_position, true); }
