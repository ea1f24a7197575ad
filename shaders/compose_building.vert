#version 310 es
// The building seen by the pinhole camera that the compositor distorts to the HMD lens. Sky
// irradiance per vertex, E_v = Σ_i S_i t_{v,i} from the baked transfer vectors, comes as an
// attribute: the compositor sums it on the CPU when the sky changes (once per new sky, not once per
// frame: on llvmpipe the vertex stage runs on one thread, and with hundreds of layers the sum was
// most of the building's pass). On a light map's chart, E_v holds the lamps alone and the atlas
// the rest (render/src/building_light.hpp).
precision highp float;
precision highp int;

layout(location = 0) in vec3 position;   // site frame, metres
layout(location = 1) in vec3 normal;
layout(location = 2) in vec2 texcoord;
layout(location = 3) in vec3 irradiance; // E_v
layout(location = 4) in vec3 ground;     // the ground's share of E_v (render.ground_light; else 0)
layout(location = 5) in vec2 atlas;      // the light map's atlas texels at this corner; (−1, −1): no chart

uniform mat4 clip_from_site;
uniform mat4 camera_from_site;

out vec3 site_position;
out vec3 site_normal;
out vec2 uv;
out vec3 sky_irradiance;
out vec3 ground_irradiance;
out vec2 light_map_at;
out float camera_depth;

// As compose_depth.vert, whose depth the colour pass tests against.
invariant gl_Position;

void main() {
  sky_irradiance = irradiance;
  ground_irradiance = ground;
  light_map_at = atlas;
  site_position = position;
  site_normal = normal;
  uv = texcoord;
  camera_depth = (camera_from_site * vec4(position, 1.0)).z;
  gl_Position = clip_from_site * vec4(position, 1.0);
}
