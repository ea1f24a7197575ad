#version 310 es
// The building seen by the pinhole camera that the compositor distorts to the HMD lens. Sky
// irradiance per vertex: E_v = Σ_i S_i t_{v,i}, from the baked transfer vectors (4 basis layers
// per RGBA texel, vertex v's texels from v·ceil(n/4) on, row after row) and S (one RGBA texel
// per layer, zero-padded to a multiple of 4).
precision highp float;
precision highp int;

layout(location = 0) in vec3 position;   // site frame, metres
layout(location = 1) in vec3 normal;
layout(location = 2) in vec2 texcoord;

uniform mat4 clip_from_site;
uniform mat4 camera_from_site;
uniform int texels_per_vertex;           // ceil(layer count / 4)
uniform int transfer_row_texels;         // the transfer texture's width
layout(binding = 0) uniform highp sampler2D transfer;
layout(binding = 1) uniform highp sampler2D sky;

out vec3 site_position;
out vec3 site_normal;
out vec2 uv;
out vec3 sky_irradiance;
out float camera_depth;

// As compose_depth.vert, whose depth the colour pass tests against.
invariant gl_Position;

void main() {
  int first = gl_VertexID * texels_per_vertex;
  vec3 irradiance = vec3(0.0);
  for (int k = 0; k < texels_per_vertex; ++k) {
    int index = first + k;
    vec4 t = texelFetch(transfer, ivec2(index % transfer_row_texels, index / transfer_row_texels), 0);
    irradiance += t.x * texelFetch(sky, ivec2(4 * k, 0), 0).rgb;
    irradiance += t.y * texelFetch(sky, ivec2(4 * k + 1, 0), 0).rgb;
    irradiance += t.z * texelFetch(sky, ivec2(4 * k + 2, 0), 0).rgb;
    irradiance += t.w * texelFetch(sky, ivec2(4 * k + 3, 0), 0).rgb;
  }
  sky_irradiance = irradiance;
  site_position = position;
  site_normal = normal;
  uv = texcoord;
  camera_depth = (camera_from_site * vec4(position, 1.0)).z;
  gl_Position = clip_from_site * vec4(position, 1.0);
}
