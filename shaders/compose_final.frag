#version 310 es
// The composite, once per camera pixel: the camera's own pixel (linearised, never resampled),
// times T where the pixel's ray meets a real plane first; then the building, looked up in the
// pinhole render at the ray's pinhole position (bilinear over the texels the building covers),
// over it, unless the real plane is nearer than the building by more than occlusion_margin.
// Then blended towards the camera's own pixel by opacity (1: the composite, 0: the camera image
// unchanged). Writes linear values and their sRGB encoding (for display).
//
// The compositor compiles it for its site with REAL_PLANES (0 … 8) real planes: code for planes
// that do not exist is not compiled (a SIMD renderer such as llvmpipe would run every branch of
// a run-time choice). FILTERED_LOOKUPS 1: the shadow ratios and the building's radiance are
// bound with a bilinear sampler (float textures are filterable), one lookup instead of four
// texel reads.
precision highp float;
precision highp int;

#ifndef REAL_PLANES
#define REAL_PLANES 8
#endif
#ifndef FILTERED_LOOKUPS
#define FILTERED_LOOKUPS 0
#endif
const int kMaxRealPlanes = 8;

uniform mat3 site_from_camera;
uniform vec3 camera_position;             // site frame
uniform vec4 pinhole;                     // fx, fy, cx, cy of the building render
uniform float occlusion_margin;
uniform float opacity;                    // in [0, 1]: 0 shows the camera image alone
uniform vec3 plane_origin[kMaxRealPlanes];
uniform vec3 plane_s_axis[kMaxRealPlanes];
uniform vec3 plane_t_axis[kMaxRealPlanes];
uniform vec3 plane_normal[kMaxRealPlanes];

layout(binding = 0) uniform highp sampler2D camera_image;   // linear (8-bit frames: sRGB8, decoded on fetch)
layout(binding = 1) uniform highp sampler2D rays;      // camera-frame unit ray, w = 1 when valid
layout(binding = 2) uniform highp sampler2D building;  // rgb radiance, a = 1 where drawn (0: none)
layout(binding = 3) uniform highp sampler2D real_ratio_0;
layout(binding = 4) uniform highp sampler2D real_ratio_1;
layout(binding = 5) uniform highp sampler2D real_ratio_2;
layout(binding = 6) uniform highp sampler2D real_ratio_3;
layout(binding = 7) uniform highp sampler2D real_ratio_4;
layout(binding = 8) uniform highp sampler2D real_ratio_5;
layout(binding = 9) uniform highp sampler2D real_ratio_6;
layout(binding = 10) uniform highp sampler2D real_ratio_7;
layout(binding = 11) uniform highp sampler2D building_depth;  // camera depth; huge where nothing is drawn

layout(location = 0) out vec4 linear_out;
layout(location = 1) out vec4 display_out;

// As compose_building.frag's.
vec3 bilinear_ratio(highp sampler2D ratio, vec2 st) {
#if FILTERED_LOOKUPS
  vec3 t = textureLod(ratio, st, 0.0).rgb;
#else
  ivec2 size = textureSize(ratio, 0);
  vec2 c = st * vec2(size) - 0.5;
  vec2 base = floor(c);
  vec2 f = c - base;
  ivec2 i0 = clamp(ivec2(base), ivec2(0), size - 1);
  ivec2 i1 = clamp(ivec2(base) + 1, ivec2(0), size - 1);
  vec3 a = texelFetch(ratio, ivec2(i0.x, i0.y), 0).rgb;
  vec3 b = texelFetch(ratio, ivec2(i1.x, i0.y), 0).rgb;
  vec3 d = texelFetch(ratio, ivec2(i0.x, i1.y), 0).rgb;
  vec3 e = texelFetch(ratio, ivec2(i1.x, i1.y), 0).rgb;
  vec3 t = mix(mix(a, b, f.x), mix(d, e, f.x), f.y);
#endif
  bvec3 bad = isnan(t);
  return vec3(bad.x ? 1.0 : clamp(t.x, 0.0, 1.0), bad.y ? 1.0 : clamp(t.y, 0.0, 1.0),
              bad.z ? 1.0 : clamp(t.z, 0.0, 1.0));
}

// Samplers may be indexed by constant expressions only (GLSL ES 3.10); only the planes that
// exist are read.
vec3 real_ratio(int j, vec2 st) {
  vec3 t = vec3(1.0);
#if REAL_PLANES > 0
  if (j == 0) t = bilinear_ratio(real_ratio_0, st);
#endif
#if REAL_PLANES > 1
  if (j == 1) t = bilinear_ratio(real_ratio_1, st);
#endif
#if REAL_PLANES > 2
  if (j == 2) t = bilinear_ratio(real_ratio_2, st);
#endif
#if REAL_PLANES > 3
  if (j == 3) t = bilinear_ratio(real_ratio_3, st);
#endif
#if REAL_PLANES > 4
  if (j == 4) t = bilinear_ratio(real_ratio_4, st);
#endif
#if REAL_PLANES > 5
  if (j == 5) t = bilinear_ratio(real_ratio_5, st);
#endif
#if REAL_PLANES > 6
  if (j == 6) t = bilinear_ratio(real_ratio_6, st);
#endif
#if REAL_PLANES > 7
  if (j == 7) t = bilinear_ratio(real_ratio_7, st);
#endif
  return t;
}

// The sRGB encoding within a quarter of an 8-bit code (sqrt is cheap where pow is not: Ian
// Taylor's fit, chilliant.blogspot.com/2012/08/srgb-approximations-for-hlsl.html); the display
// target rounds it to the nearest code, so a camera pixel shown unchanged keeps its code.
vec3 srgb_encode(vec3 l) {
  vec3 s1 = sqrt(l);
  vec3 s2 = sqrt(s1);
  vec3 s3 = sqrt(s2);
  vec3 curve = 0.662002687 * s1 + 0.684122060 * s2 - 0.323583601 * s3 - 0.0225411470 * l;
  return mix(curve, 12.92 * l, lessThanEqual(l, vec3(0.0031308)));
}

vec3 finite_or_zero(vec3 v) {
  bvec3 bad = bvec3(isnan(v.x) || isinf(v.x), isnan(v.y) || isinf(v.y), isnan(v.z) || isinf(v.z));
  return max(vec3(bad.x ? 0.0 : v.x, bad.y ? 0.0 : v.y, bad.z ? 0.0 : v.z), vec3(0.0));
}

void main() {
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  vec3 camera = texelFetch(camera_image, pixel, 0).rgb;
  vec3 background = camera;
  vec3 colour = background;
  vec4 ray = texelFetch(rays, pixel, 0);
  if (ray.w > 0.5) {
    // The nearest real plane along the ray.
    vec3 direction = site_from_camera * ray.xyz;
    float plane_distance = -1.0;
    int nearest = -1;
    vec2 nearest_st = vec2(0.0);
    for (int j = 0; j < REAL_PLANES; ++j) {
      float facing = dot(direction, plane_normal[j]);
      if (abs(facing) < 1e-9) continue;
      float distance = dot(plane_origin[j] - camera_position, plane_normal[j]) / facing;
      if (distance <= 0.0 || (plane_distance > 0.0 && distance >= plane_distance)) continue;
      vec3 offset = camera_position + distance * direction - plane_origin[j];
      vec2 st = vec2(dot(offset, plane_s_axis[j]), dot(offset, plane_t_axis[j]));
      if (any(lessThan(st, vec2(0.0))) || any(greaterThan(st, vec2(1.0)))) continue;
      plane_distance = distance;
      nearest = j;
      nearest_st = st;
    }
    // One lookup, in the nearest plane's ratio.
    if (nearest >= 0) background *= real_ratio(nearest, nearest_st);
    colour = background;

    // The building: bilinear over the four render texels around the ray's pinhole position,
    // counting only those it covers (coverage = their weight; texels not drawn hold 0), and the
    // nearest of their depths.
    vec2 q = pinhole.xy * (ray.xy / ray.z) + pinhole.zw;
#if FILTERED_LOOKUPS
    vec2 uv = (q + 0.5) / vec2(textureSize(building, 0));
    vec4 b = textureLod(building, uv, 0.0);
    vec3 sum = b.rgb;
    float coverage = b.a;
    vec4 depths = textureGather(building_depth, uv, 0);
    float depth = min(min(depths.x, depths.y), min(depths.z, depths.w));
#else
    ivec2 size = textureSize(building, 0);
    vec2 base = floor(q);
    vec2 f = q - base;
    ivec2 i0 = ivec2(base);
    vec3 sum = vec3(0.0);
    float coverage = 0.0;
    float depth = 1e30;
    for (int k = 0; k < 4; ++k) {
      ivec2 offset = ivec2(k & 1, k >> 1);
      ivec2 texel = i0 + offset;
      if (any(lessThan(texel, ivec2(0))) || any(greaterThanEqual(texel, size))) continue;
      vec4 b = texelFetch(building, texel, 0);
      if (b.a <= 0.0) continue;
      float w = (offset.x == 1 ? f.x : 1.0 - f.x) * (offset.y == 1 ? f.y : 1.0 - f.y);
      sum += w * b.rgb;
      coverage += w;
      depth = min(depth, texelFetch(building_depth, texel, 0).r);
    }
#endif
    bool hidden = plane_distance > 0.0 && plane_distance * ray.z < depth - occlusion_margin;
    if (coverage > 0.0 && !hidden) colour = sum + (1.0 - coverage) * background;
  }
  // Opacity 0 gives the camera's pixel unchanged and 1 the composite unchanged, bit for bit:
  // chosen outright, since a driver may evaluate mix as a + (b − a)·t, which rounds at t = 1.
  colour = finite_or_zero(colour);
  if (opacity <= 0.0) {
    colour = finite_or_zero(camera);
  } else if (opacity < 1.0) {
    colour = mix(finite_or_zero(camera), colour, opacity);
  }
  linear_out = vec4(colour, 1.0);
  vec3 shown = clamp(colour, 0.0, 1.0);
  display_out = vec4(srgb_encode(shown), 1.0);
}
