#version 450 core
// The globe's terrain: a hypsometric tint by height (blues below sea level; green, brown, then
// white above) times a hillshade from the screen-space normal, lit from the north-west a little
// off the local up; where the tile has imagery, the imagery (unshaded, as the projected frame's
// orthophoto) over it by its coverage; with a texture drape (the draping baseline, the projected
// frame's drape over the tile's box or the data's), its layers blended over that and their bits
// written to the mask attachment, whose writes are otherwise off in the terrain pass.
in vec3 v_position;
in vec3 v_up;
in float v_height;
in vec2 v_uv;
in vec2 v_drapeUv;

uniform sampler2D u_imagery;  // the tile's texels, row 0 at its south side
uniform int u_hasImagery;
uniform int u_hasDrape;
uniform int u_drapeTiled;               // draping per tile: the tile's layer of the arrays
uniform int u_drapeLayer;
uniform sampler2D u_drape;              // premultiplied RGBA, mip-mapped
uniform sampler2D u_drapeMask;          // R32F layer bits, read at the nearest texel
uniform sampler2DArray u_drapeTiles;    // premultiplied RGBA
uniform sampler2DArray u_drapeTileMask; // R32F layer bits

layout(location = 0) out vec4 o_color;
layout(location = 1) out vec4 o_mask;

vec3 tint(float h) {
  if (h < 0.0) return mix(vec3(0.30, 0.50, 0.72), vec3(0.08, 0.16, 0.38), clamp(-h / 6000.0, 0.0, 1.0));
  const float stops[5] = float[](0.0, 500.0, 1500.0, 3000.0, 5000.0);
  const vec3 colors[5] = vec3[](vec3(0.30, 0.55, 0.30), vec3(0.55, 0.68, 0.36), vec3(0.62, 0.52, 0.34),
                                vec3(0.50, 0.40, 0.32), vec3(0.96, 0.96, 0.96));
  for (int k = 1; k < 5; ++k) {
    if (h <= stops[k]) return mix(colors[k - 1], colors[k], (h - stops[k - 1]) / (stops[k] - stops[k - 1]));
  }
  return colors[4];
}

void main() {
  vec3 up = normalize(v_up);
  vec3 n = cross(dFdx(v_position), dFdy(v_position));
  n = dot(n, n) > 0.0 ? normalize(n) : up;
  if (dot(n, up) < 0.0) n = -n;
  vec3 east = cross(vec3(0.0, 0.0, 1.0), up);
  east = dot(east, east) > 1e-8 ? normalize(east) : vec3(0.0, 1.0, 0.0);
  vec3 north = cross(up, east);
  vec3 light = normalize(1.5 * up + 0.5 * (north - east));
  float shade = clamp(dot(n, light), 0.0, 1.0) / dot(up, light);
  vec3 color = tint(v_height) * (0.35 + 0.65 * clamp(shade, 0.0, 1.2));
  if (u_hasImagery != 0) {
    vec4 photo = texture(u_imagery, v_uv);
    color = mix(color, photo.rgb, photo.a);
  }
  o_color = vec4(color, 1.0);
  o_mask = vec4(0.0);
  // A tile's own texture covers it whole (its border's uv may round to 1); a single drape, its box.
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
