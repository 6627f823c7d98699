#version 450 core
// Terrain vertices are float relative to the mesh centre; u_modelViewProj already includes the
// translation by the centre, formed in double on the CPU (gfx::relativeToCentre).
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec2 a_imageryUv;

uniform mat4 u_modelViewProj;

out vec3 v_normal;
out vec2 v_imageryUv;

void main() {
  v_normal = a_normal;
  v_imageryUv = a_imageryUv;
  gl_Position = u_modelViewProj * vec4(a_position, 1.0);
}
