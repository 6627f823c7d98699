#version 450 core
// Texture draping (the baseline of osgEarth, MapLibre, deck.gl): a layer's footprints drawn flat
// into a texture over the terrain's extent. Positions are metres from the extent's corner.
layout(location = 0) in vec2 a_position;
layout(location = 1) in vec4 a_color;  // straight alpha

uniform vec2 u_scale;  // clip units per metre

out vec4 v_color;

void main() {
  v_color = a_color;
  gl_Position = vec4(a_position * u_scale - 1.0, 0.0, 1.0);
}
