#version 450 core
// Copies one sample of a multisampled target (colour, mask, depth) into a single-sampled one,
// for per-sample comparisons with the CPU reference.
uniform sampler2DMS u_color;
uniform sampler2DMS u_mask;
uniform sampler2DMS u_depth;
uniform int u_sample;
uniform int u_hasMask;

layout(location = 0) out vec4 o_color;
layout(location = 1) out vec4 o_mask;

void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  o_color = texelFetch(u_color, p, u_sample);
  o_mask = u_hasMask != 0 ? texelFetch(u_mask, p, u_sample) : vec4(0.0);
  gl_FragDepth = texelFetch(u_depth, p, u_sample).r;
}
