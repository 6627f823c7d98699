#version 450 core
// Orthophoto where it covers the terrain, hillshade from the screen-space normal elsewhere.
in vec3 v_position;
in vec2 v_uv;

uniform sampler2D u_imagery;
uniform int u_hasImagery;
uniform vec3 u_lightDirection;

layout(location = 0) out vec4 o_color;

void main() {
  vec3 n = normalize(cross(dFdx(v_position), dFdy(v_position)));
  if (n.z < 0.0) n = -n;
  float shade = clamp(dot(n, normalize(u_lightDirection)), 0.0, 1.0);
  vec3 hillshade = vec3(0.55, 0.57, 0.52) * (0.35 + 0.65 * shade);
  bool inside = all(greaterThanEqual(v_uv, vec2(0.0))) && all(lessThanEqual(v_uv, vec2(1.0)));
  if (u_hasImagery != 0 && inside) {
    vec4 photo = texture(u_imagery, v_uv);
    o_color = vec4(mix(hillshade, photo.rgb, photo.a), 1.0);
  } else {
    o_color = vec4(hillshade, 1.0);
  }
}
