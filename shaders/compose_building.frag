#version 310 es
// The building's radiance in camera units, k ⊙ ρ/π · E (alpha 1: drawn), and its camera depth
// (a second target). E is exact from a virtual plane's shadow ratio where one covers the
// fragment, T_j ⊙ D_j (D_j = Σ S_i A_{j,i} + E_sun max(0, n_j·ω_sun), from the CPU), and the
// interpolated transfer sum plus the sun (its shadow map's visibility) elsewhere.
//
// The compositor compiles it for its site: VIRTUAL_PLANES (0 … 8) virtual planes, and
// SUN_SHADOWS 1 with a sun shadow map bound, 0 without (the sun term then unshadowed). The
// virtual planes' T come as one texture array, a layer per plane (render/plane_ratio_array.hpp):
// a fragment reads the one plane that covers it, where a sampler per plane would have a SIMD
// renderer such as llvmpipe, which runs every branch of a run-time choice, read them all.
// FILTERED_LOOKUPS 1: the shadow ratios are bound with a bilinear sampler (float textures are
// filterable), one lookup instead of four texel reads.
// LIGHT_MAP 1: the bake's light map is bound; on its charts the sky's and the ground's light come
// from its atlas (bilinear between texel centres) instead of from the triangle's corners.
// library: sun_shadow.glsl
precision highp float;
precision highp int;

#ifndef VIRTUAL_PLANES
#define VIRTUAL_PLANES 8
#endif
#ifndef FILTERED_LOOKUPS
#define FILTERED_LOOKUPS 0
#endif
#ifndef LIGHT_MAP
#define LIGHT_MAP 0
#endif
#ifndef SUN_SHADOWS
#define SUN_SHADOWS 1
#endif
// The library reads the shadow map's minimum/maximum pyramid (SunShadowMap::bind with two units).
#define SUN_SHADOW_MINMAX 1

const int kMaxVirtualPlanes = 8;
const float kPi = 3.14159265358979;

in vec3 site_position;
in vec3 site_normal;
in vec2 uv;
in vec3 sky_irradiance;
in vec3 ground_irradiance;      // its ground share (render.ground_light)
in vec2 light_map_at;           // atlas texels; negative: the triangle lies on no chart
in float camera_depth;

uniform vec3 base_colour;                 // linear glTF baseColorFactor
uniform vec3 photometric_scale;           // k
uniform vec3 sun_direction;               // unit, towards the sun
uniform vec3 sun_energy;                  // E_sun; zero without a sun
uniform float cover_distance;
uniform float cover_cos;
uniform vec3 plane_origin[kMaxVirtualPlanes];
uniform vec3 plane_s_axis[kMaxVirtualPlanes];   // s = dot(x − origin, s_axis): the dual basis of (u, v)
uniform vec3 plane_t_axis[kMaxVirtualPlanes];
uniform vec3 plane_normal[kMaxVirtualPlanes];
uniform vec3 plane_irradiance[kMaxVirtualPlanes];
uniform vec2 plane_texels[kMaxVirtualPlanes];    // its T's width and height: the first of its layer's texels

layout(binding = 2) uniform highp sampler2D albedo_texture;   // sRGB8_ALPHA8: decoded on fetch
#if VIRTUAL_PLANES > 0
layout(binding = 4) uniform highp sampler2DArray plane_ratios;   // layer j: plane j's T, RGBA32F
#endif
#if LIGHT_MAP
layout(binding = 5) uniform highp sampler2D light_map;           // E of the sky and the ground, RGBA32F
uniform vec2 light_map_size;                                     // the atlas, texels
#endif

layout(location = 0) out vec4 result;
layout(location = 1) out float result_depth;

// Bilinear T of plane j at its coordinates (s, t), texel centres at ((col + ½)/W, (row + ½)/H),
// clamped to the plane's edge texels (its layer is larger where another plane is): through the
// bound sampler, or with texelFetch so that no texture format needs to be filterable. A NaN
// becomes 1 (no shadow) and everything else is clamped to [0, 1], as the CPU blend guarantees.
vec3 plane_ratio(int j, vec2 st) {
#if VIRTUAL_PLANES > 0
  vec2 size = plane_texels[j];
#if FILTERED_LOOKUPS
  // Between the first and the last texel centre: the edge texel's neighbour takes weight 0.
  vec2 layer = vec2(textureSize(plane_ratios, 0).xy);
  vec2 c = clamp(st * size, vec2(0.5), size - 0.5) / layer;
  vec3 t = textureLod(plane_ratios, vec3(c, float(j)), 0.0).rgb;
#else
  ivec2 last = ivec2(size) - 1;
  vec2 c = st * size - 0.5;
  vec2 base = floor(c);
  vec2 f = c - base;
  ivec2 i0 = clamp(ivec2(base), ivec2(0), last);
  ivec2 i1 = clamp(ivec2(base) + 1, ivec2(0), last);
  vec3 a = texelFetch(plane_ratios, ivec3(i0.x, i0.y, j), 0).rgb;
  vec3 b = texelFetch(plane_ratios, ivec3(i1.x, i0.y, j), 0).rgb;
  vec3 d = texelFetch(plane_ratios, ivec3(i0.x, i1.y, j), 0).rgb;
  vec3 e = texelFetch(plane_ratios, ivec3(i1.x, i1.y, j), 0).rgb;
  vec3 t = mix(mix(a, b, f.x), mix(d, e, f.x), f.y);
#endif
  bvec3 bad = isnan(t);
  return vec3(bad.x ? 1.0 : clamp(t.x, 0.0, 1.0), bad.y ? 1.0 : clamp(t.y, 0.0, 1.0),
              bad.z ? 1.0 : clamp(t.z, 0.0, 1.0));
#else
  return vec3(1.0);
#endif
}

#if LIGHT_MAP
// The light map at atlas texel coordinates a (texel centres at +½): bilinear, through the bound
// sampler or with texelFetch. A chart has a texel beyond each edge of its faces, so that the four
// texels read are the chart's own.
vec3 light_map_irradiance(vec2 a) {
#if FILTERED_LOOKUPS
  return textureLod(light_map, a / light_map_size, 0.0).rgb;
#else
  ivec2 last = ivec2(light_map_size) - 1;
  vec2 c = a - 0.5;
  vec2 base = floor(c);
  vec2 f = c - base;
  ivec2 i0 = clamp(ivec2(base), ivec2(0), last);
  ivec2 i1 = clamp(ivec2(base) + 1, ivec2(0), last);
  vec3 p = texelFetch(light_map, i0, 0).rgb;
  vec3 q = texelFetch(light_map, ivec2(i1.x, i0.y), 0).rgb;
  vec3 r = texelFetch(light_map, ivec2(i0.x, i1.y), 0).rgb;
  vec3 s = texelFetch(light_map, i1, 0).rgb;
  return mix(mix(p, q, f.x), mix(r, s, f.x), f.y);
#endif
}
#endif

// Visible fraction of the sun's disc where `needed`, 1 elsewhere (shaders/sun_shadow.glsl,
// appended to this file).
float sun_visibility_if(vec3 world_position, bool needed);

void main() {
  vec3 n = normalize(site_normal);
  // The nearest virtual plane that covers the fragment, if any.
  int covering = -1;
  float nearest = cover_distance;
  vec2 covering_st = vec2(0.0);
  for (int j = 0; j < VIRTUAL_PLANES; ++j) {
    vec3 offset = site_position - plane_origin[j];
    float distance = abs(dot(offset, plane_normal[j]));
    vec2 st = vec2(dot(offset, plane_s_axis[j]), dot(offset, plane_t_axis[j]));
    if (distance <= nearest && dot(n, plane_normal[j]) >= cover_cos && all(greaterThanEqual(st, vec2(0.0))) &&
        all(lessThanEqual(st, vec2(1.0)))) {
      covering = j;
      nearest = distance;
      covering_st = st;
    }
  }
  // A covered fragment takes T_j D_j; elsewhere the transfer sum and the sun, whose shadow map is
  // needed only where the sun can light the fragment at all (llvmpipe runs both branches).
  vec3 irradiance;
  float facing = max(0.0, dot(n, sun_direction));
#if SUN_SHADOWS
  facing *= sun_visibility_if(site_position, covering < 0 && facing > 0.0 && any(greaterThan(sun_energy, vec3(0.0))));
#endif
  if (covering >= 0) {
    // The plane's T holds the sky and the sources; the ground's light comes from the vertices.
    // (A SIMD renderer runs this for uncovered fragments too, masked: keep their index in range.)
    int j = max(covering, 0);
    irradiance = plane_ratio(j, covering_st) * plane_irradiance[j] + ground_irradiance;
  } else {
    irradiance = sky_irradiance + sun_energy * facing;
#if LIGHT_MAP
    if (light_map_at.x >= 0.0) irradiance += light_map_irradiance(light_map_at);
#endif
  }
  vec3 albedo = base_colour * texture(albedo_texture, uv).rgb;
  vec3 radiance = photometric_scale * albedo / kPi * irradiance;
  bvec3 bad = isnan(radiance);
  radiance = vec3(bad.x ? 0.0 : radiance.x, bad.y ? 0.0 : radiance.y, bad.z ? 0.0 : radiance.z);
  result = vec4(max(radiance, vec3(0.0)), 1.0);
  result_depth = camera_depth;
}
