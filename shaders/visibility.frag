#version 310 es
// Visibility of one sample point (plane texel or nudged vertex) for a batch of directions:
// writes the occluded weight per layer and the visible count,
//     (Σ_s w_0s c_s (1 − V_s), Σ_s w_1s c_s (1 − V_s), Σ_s w_2s c_s (1 − V_s), Σ_s V_s)
// with c_s = max(0, n·ω_s), w_ks the direction's weight in layer k (faces basis: (1, 0, 0);
// corners: its barycentric coordinates in the face) and V_s from the shadow map of ω_s (one
// depth comparison at the nearest texel: binary visibility, like a ray). The CPU adds the
// batches, computes the denominators D_k = Σ_s w_ks c_s itself and forms f_k = 1 − O_k / D_k
// (exactly 1 where nothing is occluded, exactly 0 where nothing is visible), or Σ V / K when
// D_k = 0.
precision highp float;
precision highp int;
precision highp sampler2DArrayShadow;

const int kMaxLights = 64;  // the engine's batch size limit; 5 KiB of uniform block

layout(std140, binding = 0) uniform Lights {
  mat4 shadow_from_world[kMaxLights];  // world → (s, t, depth), each in [0, 1] inside the map
  vec4 light_direction[kMaxLights];    // xyz: unit direction towards the sky
  vec4 light_weight[kMaxLights];       // xyz: the direction's weight in layers 0, 1, 2
};

uniform int light_count;
// World distance the point moves towards the light before the comparison, so that a surface
// within this distance does not shadow it (the ray engine's tnear).
uniform float depth_bias;
layout(binding = 0) uniform sampler2DArrayShadow shadow_maps;  // compare mode LEQUAL, NEAREST

in vec3 sample_position;
flat in vec3 sample_normal;

layout(location = 0) out vec4 sums;

void main() {
  vec4 total = vec4(0.0);
  for (int k = 0; k < light_count; ++k) {
    vec3 direction = light_direction[k].xyz;
    vec4 q = shadow_from_world[k] * vec4(sample_position + depth_bias * direction, 1.0);
    float visible = 1.0;
    // Outside the map (cannot happen inside the bounding sphere) nothing of the model is seen.
    if (all(greaterThanEqual(q.xy, vec2(0.0))) && all(lessThanEqual(q.xy, vec2(1.0))) && q.z < 1.0) {
      visible = texture(shadow_maps, vec4(q.xy, float(k), q.z));
    }
    float c = max(0.0, dot(sample_normal, direction));
    total += vec4(light_weight[k].xyz * (c * (1.0 - visible)), visible);
  }
  sums = total;
}
