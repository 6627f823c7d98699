#version 450 core
// A vertex of a stencil polyhedron on the globe: its ECEF position split into high and low parts
// (globe/ellipsoid.hpp, SplitPosition), made relative to the eye in two exact-ish float
// subtractions, so that no float holds an earth-sized coordinate. Caps (side ±1) move out along
// the surface normal by a pad that grows with the distance from the eye (depth resolution).
layout(location = 0) in vec3 a_high;
layout(location = 1) in vec3 a_low;
layout(location = 2) in vec3 a_normal;
layout(location = 3) in float a_side;

uniform mat4 u_eyeViewProj;  // eye-relative → clip (rotation and projection only)
uniform vec3 u_eyeHigh;
uniform vec3 u_eyeLow;
uniform float u_padBase;
uniform float u_padPerMetre;
uniform vec4 u_color;

out vec4 v_color;

void main() {
  precise vec3 p = (a_high - u_eyeHigh) + (a_low - u_eyeLow);
  const float distance = length(p);
  p += a_normal * (a_side * (u_padBase + u_padPerMetre * distance));
  v_color = u_color;
  gl_Position = u_eyeViewProj * vec4(p, 1.0);
}
