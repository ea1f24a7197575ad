#version 310 es
// The device's copy bandwidth for bench/gpu_blend_bench: one 16-byte word per invocation from
// one buffer to another (what a memory-bound kernel can move; glCopyBufferSubData may run on a
// slower copy engine). Rows of the dispatch continue the word index past 65535 work groups.
layout(local_size_x = 256) in;

layout(std430, binding = 0) readonly buffer Source {
  uvec4 source[];
};
layout(std430, binding = 1) writeonly buffer Target {
  uvec4 target[];
};

void main() {
  uint i = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x + gl_GlobalInvocationID.x;
  target[i] = source[i];
}
