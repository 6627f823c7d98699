#version 450 core
// Orthophoto colour where the imagery covers the terrain; a hillshade elsewhere and when the
// scene has no imagery.
in vec3 v_normal;
in vec2 v_imageryUv;

uniform sampler2D u_imagery;
uniform int u_hasImagery;
uniform vec3 u_lightDirection;  // towards the light, frame coordinates

layout(location = 0) out vec4 o_color;

void main() {
  vec3 n = normalize(v_normal);
  float shade = clamp(dot(n, normalize(u_lightDirection)), 0.0, 1.0);
  vec3 hillshade = vec3(0.55, 0.57, 0.52) * (0.35 + 0.65 * shade);
  bool inside = all(greaterThanEqual(v_imageryUv, vec2(0.0))) && all(lessThanEqual(v_imageryUv, vec2(1.0)));
  if (u_hasImagery != 0 && inside) {
    vec4 photo = texture(u_imagery, v_imageryUv);
    o_color = vec4(mix(hillshade, photo.rgb, photo.a), 1.0);
  } else {
    o_color = vec4(hillshade, 1.0);
  }
}
