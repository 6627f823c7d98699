#version 450 core
// Orthophoto where it covers the terrain, hillshade from the screen-space normal elsewhere (grey,
// or an elevation ramp's colour at the true height: terrain::ElevationRamp::colorAt); with
// a texture drape (the draping baseline) its layers blended over, and its layer bits written to
// the mask attachment (the terrain pass then runs with mask writes on).
in vec3 v_position;
in float v_height;
in vec2 v_uv;
in vec2 v_drapeUv;

uniform sampler2D u_imagery;
uniform int u_hasImagery;
uniform vec3 u_lightDirection;
uniform int u_hasRamp;
uniform float u_rampLow;    // t = (height - low) * scale
uniform float u_rampScale;
uniform int u_rampStops;    // 2 ... 8
uniform float u_rampT[8];   // increasing, 0 ... 1
uniform vec3 u_rampColors[8];
uniform sampler2D u_drape;       // premultiplied RGBA, mip-mapped
uniform sampler2D u_drapeMask;   // R32F layer bits, read at the nearest texel
uniform int u_hasDrape;
uniform int u_drapeTiled;               // draping per tile: the chunk's layer of the arrays
uniform int u_drapeLayer;
uniform sampler2DArray u_drapeTiles;    // premultiplied RGBA
uniform sampler2DArray u_drapeTileMask; // R32F layer bits

layout(location = 0) out vec4 o_color;
layout(location = 1) out vec4 o_mask;

// As ElevationRamp::colorAt: the first segment whose upper stop reaches t.
vec3 rampColor(float t) {
  int k = 1;
  while (k + 1 < u_rampStops && t > u_rampT[k]) ++k;
  float f = clamp((t - u_rampT[k - 1]) / (u_rampT[k] - u_rampT[k - 1]), 0.0, 1.0);
  return u_rampColors[k - 1] * (1.0 - f) + u_rampColors[k] * f;
}

void main() {
  vec3 n = normalize(cross(dFdx(v_position), dFdy(v_position)));
  if (n.z < 0.0) n = -n;
  float shade = clamp(dot(n, normalize(u_lightDirection)), 0.0, 1.0);
  vec3 hillshade = vec3(0.55, 0.57, 0.52) * (0.35 + 0.65 * shade);
  if (u_hasRamp != 0) hillshade = rampColor(clamp((v_height - u_rampLow) * u_rampScale, 0.0, 1.0)) * (0.35 + 0.65 * shade);
  bool inside = all(greaterThanEqual(v_uv, vec2(0.0))) && all(lessThanEqual(v_uv, vec2(1.0)));
  if (u_hasImagery != 0 && inside) {
    vec4 photo = texture(u_imagery, v_uv);
    o_color = vec4(mix(hillshade, photo.rgb, photo.a), 1.0);
  } else {
    o_color = vec4(hillshade, 1.0);
  }
  o_mask = vec4(0.0);
  // A chunk's own tile covers it whole (its border's uv may round to 1); a single drape, its extent.
  bool onDrape = u_drapeTiled != 0 ||
                 (all(greaterThanEqual(v_drapeUv, vec2(0.0))) && all(lessThan(v_drapeUv, vec2(1.0))));
  if (u_hasDrape != 0 && onDrape) {
    vec4 layers;
    if (u_drapeTiled != 0) {
      layers = texture(u_drapeTiles, vec3(v_drapeUv, float(u_drapeLayer)));
      ivec2 size = textureSize(u_drapeTileMask, 0).xy;
      ivec2 texel = clamp(ivec2(floor(v_drapeUv * vec2(size))), ivec2(0), size - 1);
      o_mask.r = texelFetch(u_drapeTileMask, ivec3(texel, u_drapeLayer), 0).r;
    } else {
      layers = texture(u_drape, v_drapeUv);
      ivec2 size = textureSize(u_drapeMask, 0);
      o_mask.r = texelFetch(u_drapeMask, ivec2(floor(v_drapeUv * vec2(size))), 0).r;
    }
    o_color.rgb = o_color.rgb * (1.0 - layers.a) + layers.rgb;
  }
}
