#version 310 es
// Shadow-map pass: nothing to write but depth, which the fixed function does (with the
// slope-scaled glPolygonOffset set by the engine).
void main() {
}
