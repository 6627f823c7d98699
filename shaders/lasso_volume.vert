#version 450 core
// A vertex of a lasso selection volume, homogeneous and relative to the eye (w = 0 for the
// dark cap at infinity); the CPU has already clipped the triangles just in front of the eye.
layout(location = 0) in vec4 a_position;

uniform mat4 u_modelViewProj;  // frame → clip, translated to the eye
uniform vec4 u_color;          // "show volumes" only (straight alpha)

out vec4 v_color;

void main() {
  v_color = u_color;
  gl_Position = u_modelViewProj * a_position;
}
