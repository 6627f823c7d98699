#version 450 core
// The cover pass of a layer whose features share one colour: a screen rectangle (normalised
// device coordinates) over everything the layer's visible pieces can have marked. The stencil
// test picks the marked pixels; the rectangle's vertices cost nothing next to the pieces'.
uniform vec4 u_rect;  // x0, y0, x1, y1
uniform vec4 u_color;

out vec4 v_color;

void main() {
  const vec2 corner = vec2(gl_VertexID & 1, gl_VertexID >> 1);
  v_color = u_color;
  gl_Position = vec4(mix(u_rect.xy, u_rect.zw, corner), 0.0, 1.0);
}
