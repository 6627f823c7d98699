#version 450 core
// A vertex of a stencil polyhedron: (x, y) relative to its origin, the height of its cap (the
// height bound) and the side (−1 bottom, +1 top). The origin arrives per draw as an instanced
// attribute (baseInstance), already relative to the eye, so every float stays small near the
// eye. Caps move out by a pad that grows with the distance from the eye (depth resolution).
//
// Both frames draw with it (docs/frames.md): in a projected frame z is up and caps move along it;
// on the globe (u_alongNormals) a_position holds ECEF metres relative to the tile's origin, and
// caps move along the surface normal a_up.xyz, pieces built for the finer terrain only further by
// u_capReach (OverlayLayer::capReach).
//
// Lines in pixels: (x, y) is the centre the vertex belongs to, a_scaling its direction, the
// centre's anchor height and the least half width; the vertex lies at centre + direction · h
// with the half width h = max(min(u_halfWidthPerMetre · distance from the eye to the anchored
// centre, u_maxHalfWidth), least half width) (footprints.hpp, LineShape). Other layers leave
// the attribute disabled: (0, 0, 0, 1), no offset. On the globe a_position is the centre at the
// cap's height, a_scaling.xyz its direction (ECEF, in the tangent plane there), a_scaling.w the
// least half width, and the anchored centre lies a_up.w along the normal from it.
layout(location = 0) in vec4 a_position;
layout(location = 1) in vec4 a_color;
layout(location = 2) in vec3 a_origin;
layout(location = 3) in vec4 a_scaling;
layout(location = 4) in vec4 a_up;  // u_alongNormals: the surface normal there; w: to the anchor

uniform mat4 u_modelViewProj;  // frame → clip, translated to the eye
uniform float u_padBase;
uniform float u_padPerMetre;
uniform float u_padPerMetreSquared;  // fixed-point depth buffers: their steps grow with distance²
uniform float u_halfWidthPerMetre;
uniform float u_maxHalfWidth;
uniform vec4 u_debugColor;  // alpha > 0: every vertex takes this colour (the debug view of pieces)
uniform bool u_alongNormals;  // caps padded along a_up (the globe), else along z
uniform vec2 u_capReach;      // u_alongNormals: bottom caps move down by x, top caps up by y

out vec4 v_color;

void main() {
  vec3 p = vec3(a_position.xy + a_origin.xy, a_position.z + a_origin.z);
  if (u_alongNormals) {
    const vec3 centre = p + a_up.xyz * a_up.w;
    p += a_scaling.xyz * max(min(u_halfWidthPerMetre * length(centre), u_maxHalfWidth), a_scaling.w);
  } else {
    const vec3 centre = vec3(p.xy, a_scaling.z + a_origin.z);
    p.xy += a_scaling.xy * max(min(u_halfWidthPerMetre * length(centre), u_maxHalfWidth), a_scaling.w);
  }
  const float distance = length(p);
  const float pad = a_position.w * (u_padBase + (u_padPerMetre + u_padPerMetreSquared * distance) * distance);
  if (u_alongNormals) {
    p += a_up.xyz * (pad + (a_position.w < 0.0 ? -u_capReach.x : u_capReach.y));
  } else {
    p.z += pad;
  }
  v_color = u_debugColor.a > 0.0 ? u_debugColor : a_color;
  gl_Position = u_modelViewProj * vec4(p, 1.0);
}
