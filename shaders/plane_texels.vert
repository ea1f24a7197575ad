#version 310 es
// Visibility pass over a plane: a full-viewport quad (triangle strip, 4 vertices, no attributes)
// whose corners carry the world positions of the tile's corners. Interpolated linearly, the
// position at a pixel centre is the centre of the plane texel: origin + (col+0.5)/W·u +
// (row+0.5)/H·v, with row 0 at the bottom of the viewport (glReadPixels' first row).
uniform highp vec3 tile_origin;  // world position of the tile's corner (col0, row0)
uniform highp vec3 tile_u;       // world vector across the tile's columns
uniform highp vec3 tile_v;       // world vector across the tile's rows
uniform highp vec3 plane_normal;

out highp vec3 sample_position;
flat out highp vec3 sample_normal;

void main() {
  vec2 corner = vec2(float(gl_VertexID & 1), float(gl_VertexID >> 1));
  sample_position = tile_origin + corner.x * tile_u + corner.y * tile_v;
  sample_normal = plane_normal;
  gl_Position = vec4(corner * 2.0 - 1.0, 0.0, 1.0);
}
