#version 450 core
// A post of a globe terrain tile, drawn relative to the eye (docs/globe.md): its ECEF position
// split into a multiple of 16 m and the rest. (high − eyeHigh) is exact in float and (low − eyeLow)
// keeps micrometres, so a post shared by two tiles lands on the same clip coordinates in both.
layout(location = 0) in vec3 a_high;
layout(location = 1) in vec3 a_low;
layout(location = 2) in float a_height;

uniform mat4 u_eyeViewProj;  // eye-relative → clip (rotation and projection only)
uniform vec3 u_eyeHigh;
uniform vec3 u_eyeLow;
uniform vec2 u_drapeUvBase;   // texture drape: the tile's south-west corner in the drape's uv
uniform vec2 u_drapeUvScale;  // and the tile's size there

out vec3 v_position;  // eye-relative, metres
out vec3 v_up;        // the geocentric direction: near enough the local up for lighting
out float v_height;   // metres above the ellipsoid
out vec2 v_uv;        // the tile's imagery texture: post (i, j) at (i, j) / 32, exactly
out vec2 v_drapeUv;   // a drape's (linear in longitude and latitude, as the tile)

void main() {
  precise vec3 p = (a_high - u_eyeHigh) + (a_low - u_eyeLow);
  v_position = p;
  v_up = normalize(a_high + a_low);
  v_height = a_height;
  // The vertex is post (i, j) = (id mod 33, id / 33) of its tile (globe_terrain.cpp: postIndex).
  v_uv = vec2(float(gl_VertexID % 33), float(gl_VertexID / 33)) / 32.0;
  v_drapeUv = u_drapeUvBase + v_uv * u_drapeUvScale;
  gl_Position = u_eyeViewProj * vec4(p, 1.0);
}
