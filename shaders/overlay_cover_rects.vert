#version 450 core
// The cover pass of a layer whose features share one colour, over screen tiles: disjoint screen
// rectangles (normalised device coordinates, one per instance) over everything the layer's
// visible pieces can have marked. The stencil test picks the marked pixels.
layout(std430, binding = 3) readonly buffer CoverRects {
  vec4 rects[];  // x0, y0, x1, y1
};
uniform vec4 u_color;

out vec4 v_color;

void main() {
  const vec2 corner = vec2(gl_VertexID & 1, gl_VertexID >> 1);
  const vec4 rect = rects[gl_InstanceID];
  v_color = u_color;
  gl_Position = vec4(mix(rect.xy, rect.zw, corner), 0.0, 1.0);
}
