#version 450 core
// A quadtree chunk: xy relative to the chunk centre (u_modelViewProj holds the translation,
// formed in double on the CPU), raw height scaled by the exaggeration. Odd edge vertices take
// the coarser neighbour's edge height where u_stitchMask has their edge's bit.
layout(location = 0) in vec2 a_xy;
layout(location = 1) in float a_height;
layout(location = 2) in float a_stitchHeight;
layout(location = 3) in uint a_edges;

uniform mat4 u_modelViewProj;
uniform uint u_stitchMask;
uniform float u_exaggeration;
uniform vec2 u_uvBase;   // imagery uv of the chunk centre
uniform vec2 u_uvScale;  // uv per metre

out vec3 v_position;
out vec2 v_uv;

void main() {
  float h = (a_edges & u_stitchMask) != 0u ? a_stitchHeight : a_height;
  vec3 p = vec3(a_xy, h * u_exaggeration);
  v_position = p;
  v_uv = u_uvBase + a_xy * u_uvScale;
  gl_Position = u_modelViewProj * vec4(p, 1.0);
}
