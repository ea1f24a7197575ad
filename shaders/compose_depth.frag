#version 310 es
// The building's depth pre-pass: depth only, which the fixed function writes.
void main() {
}
