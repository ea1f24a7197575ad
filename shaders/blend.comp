#version 310 es
// Shadow ratios of one plane (blend/gpu_blend.hpp): per texel
//     T = Σ_i w_i B_i + Σ_k w_k V_k     per colour channel, fp32 (k: the separated sources, the sun first),
// then a channel without light is 1 and T is clamped to [0, 1], as blend_cpu does. One
// invocation per texel. The basis array holds one layer per slice (R16F, R8, R11 EAC) or
// several, one per colour channel (RGBA16F, RGBA8: four; RG11 EAC: two); the CPU lists the
// slices to read with the weights of their layers, so that one fetch and three dot products add
// up to four layers. A tiled (clustered PCA) basis has a weight list per tile over the same
// slices: entries t·slice_count … of tile t.
//
// Paged (a cropped basis): the array is an atlas of pages of tile_size × tile_size texels, each
// holding up to four layers over one tile of the plane. Tile t's record gives its constant (the
// weighted fills of the summed layers that have no page in the tile), which the sum starts from,
// and its entries of `slices`: range.y entries from range.x, each naming its page's array layer
// (index.x) and the page's corner in it (index.yz); the texel reads its offset from the tile's
// corner there. Unpaged, index.yz is 0 and every texel reads its own texel of the slice.
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp sampler2DArray;
precision highp image2D;

// The loader defines SKYLIT_T_FORMAT as rgba32f for a float shadow-ratio texture.
#ifndef SKYLIT_T_FORMAT
#define SKYLIT_T_FORMAT rgba16f
#endif

layout(local_size_x = 8, local_size_y = 8) in;

// The weights of a slice's layers (times their scale for 8-bit and EAC storage), one vec4 per
// colour channel with a layer per component (unused components 0), and where to read the slice.
struct Slice {
  vec4 red;
  vec4 green;
  vec4 blue;
  ivec4 index;  // x: array layer; yz: the page's corner in it (paged; 0 otherwise)
};
layout(std430, binding = 0) readonly buffer Slices {
  Slice slices[];
};

// Paged: per tile of the plane, the start of its sum and its entries of `slices`.
struct TileRange {
  vec4 constant;  // rgb: Σ w_k fill_k over the summed layers without a page in the tile
  ivec4 range;    // x: first entry, y: entry count
};
layout(std430, binding = 1) readonly buffer Tiles {
  TileRange tiles[];
};

uniform int slice_count;   // entries of `slices` to sum (per tile; unpaged)
uniform int tile_size;     // texels per side of a tile (clustered PCA, or a page); 0: one tile, the plane
uniform int tiles_x;       // tiles per row of tiles (row-major tile index)
uniform bool paged;        // a cropped basis in pages (the tile records say what to read)
// The separated sources that light the plane: xyz w_k, w the layer of `source_visibility` that
// holds V_k. Only the first source_count entries are read (0: no separated term).
const int kMaxSources = 32;  // blend::kMaxGpuSources
uniform vec4 source_term[kMaxSources];
uniform int source_count;
uniform bvec3 no_light;    // channels whose T is 1

layout(binding = 0) uniform sampler2DArray basis;       // B: a layer per slice or per channel
layout(binding = 1) uniform sampler2DArray source_visibility;   // V_k in red of a layer, same texels as B
layout(SKYLIT_T_FORMAT, binding = 0) writeonly uniform image2D shadow_ratio;

void main() {
  ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
  ivec2 size = imageSize(shadow_ratio);
  if (texel.x >= size.x || texel.y >= size.y) return;

  // This texel's tile (0 for an untiled basis): unpaged, its weights are the slice_count entries
  // from `base`, over the same slices as every other tile's; paged, the tile's record says.
  int tile = tile_size > 0 ? (texel.y / tile_size) * tiles_x + texel.x / tile_size : 0;
  int base = tile * slice_count;
  int count = slice_count;
  vec3 sum = vec3(0.0);
  ivec2 at = texel;  // where in a slice (paged: added to the page's corner)
  if (paged) {
    base = tiles[tile].range.x;
    count = tiles[tile].range.y;
    sum = tiles[tile].constant.xyz;
    at = texel - (texel / tile_size) * tile_size;
  }

  // Four fetches are issued before their sums: a single one in flight per invocation leaves
  // the memory idle while it waits (measured on an H100: one 512² plane of 640 layers took 5×
  // its bandwidth floor). The sums still run in slice order. An R16F or R8 slice reads
  // (b, 0, 0, 1): its weights sit in x alone.
  int k = 0;
  for (; k + 4 <= count; k += 4) {
    int s = base + k;
    vec4 b0 = texelFetch(basis, ivec3(slices[s].index.yz + at, slices[s].index.x), 0);
    vec4 b1 = texelFetch(basis, ivec3(slices[s + 1].index.yz + at, slices[s + 1].index.x), 0);
    vec4 b2 = texelFetch(basis, ivec3(slices[s + 2].index.yz + at, slices[s + 2].index.x), 0);
    vec4 b3 = texelFetch(basis, ivec3(slices[s + 3].index.yz + at, slices[s + 3].index.x), 0);
    sum += vec3(dot(slices[s].red, b0), dot(slices[s].green, b0), dot(slices[s].blue, b0));
    sum += vec3(dot(slices[s + 1].red, b1), dot(slices[s + 1].green, b1), dot(slices[s + 1].blue, b1));
    sum += vec3(dot(slices[s + 2].red, b2), dot(slices[s + 2].green, b2), dot(slices[s + 2].blue, b2));
    sum += vec3(dot(slices[s + 3].red, b3), dot(slices[s + 3].green, b3), dot(slices[s + 3].blue, b3));
  }
  for (; k < count; ++k) {
    int s = base + k;
    vec4 b = texelFetch(basis, ivec3(slices[s].index.yz + at, slices[s].index.x), 0);
    sum += vec3(dot(slices[s].red, b), dot(slices[s].green, b), dot(slices[s].blue, b));
  }
  for (int j = 0; j < source_count; ++j) {
    // blend_cpu rejects a V outside [0, 1]; here it is clamped (NaN to 0).
    float v = texelFetch(source_visibility, ivec3(texel, int(source_term[j].w)), 0).r;
    v = v > 1.0 ? 1.0 : (v >= 0.0 ? v : 0.0);
    sum += source_term[j].xyz * v;
  }
  vec3 t;
  for (int c = 0; c < 3; ++c) {
    float x = sum[c];
    // Written with comparisons rather than clamp(), whose result for NaN is undefined: NaN → 0.
    t[c] = no_light[c] ? 1.0 : (x > 1.0 ? 1.0 : (x >= 0.0 ? x : 0.0));
  }
  imageStore(shadow_ratio, texel, vec4(t, 1.0));
}
