#version 450
// The preview's display pass, vertex stage: one triangle that covers the viewport,
// made from gl_VertexID alone (no vertex buffers).

void main() {
    vec2 corner = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);  // (0,0), (2,0), (0,2)
    gl_Position = vec4(2.0 * corner - 1.0, 0.0, 1.0);
}
