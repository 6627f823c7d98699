#version 450 core
// Mark passes write no colour (colour mask off); cover passes write the feature's colour,
// premultiplied, and add the layer's bit to the mask attachment (alpha 0: the blend adds).
in vec4 v_color;

uniform float u_maskBit;

layout(location = 0) out vec4 o_color;
layout(location = 1) out vec4 o_mask;

void main() {
  o_color = vec4(v_color.rgb * v_color.a, v_color.a);
  o_mask = vec4(u_maskBit, 0.0, 0.0, 0.0);
}
