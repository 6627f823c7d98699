#version 450 core
// The deferred technique (vector_overlay/src/deferred_index.hpp): per pixel (per sample with
// MULTISAMPLE), the terrain point from the depth buffer, found in the layer's quadtree as
// integer cells plus a remainder (never as an absolute float position), and tested against
// what the leaf lists: polygons by the parity of a path inside the leaf, lines by the CPU
// reference's primitives. deferred_index.cpp's coveringFeature is this test on the CPU.
layout(std430, binding = 4) readonly buffer Nodes {
  uvec4 nodes[];  // first, count (0xFFFFFFFF: internal), reference point x, y (float bits)
};
layout(std430, binding = 5) readonly buffer Groups {
  uvec4 groups[];  // feature, parity, first edge, edge count
};
layout(std430, binding = 6) readonly buffer Edges {
  vec4 edges[];  // per edge: (a, b), (crossY, flags bits, -, -)
};
layout(std430, binding = 7) readonly buffer Items {
  vec4 items[];  // per item four vec4 (deferred::Item)
};
layout(std430, binding = 8) readonly buffer Features {
  vec4 features[];  // per feature: colour (straight alpha), (widthPixels/2, minWidth/2, width/2, -)
};

#ifdef MULTISAMPLE
uniform sampler2DMS u_depth;
#else
uniform sampler2D u_depth;
#endif
uniform mat4 u_inverse;  // normalised device coordinates → frame coordinates relative to the eye
uniform vec2 u_viewport;
uniform ivec2 u_eyeCell;  // the eye in cells of the finest level ...
uniform vec2 u_eyeRemainder;  // ... plus this (metres)
uniform float u_eyeZ;
uniform float u_cellSize;  // metres
uniform int u_depthLevels;  // the finest level
uniform int u_polygons;  // 1: a polygon layer, 0: lines
uniform float u_metresPerPixel;
uniform float u_maskBit;

layout(location = 0) out vec4 o_color;
layout(location = 1) out vec4 o_mask;

const uint kInternal = 0xFFFFFFFFu;
const uint kCrossesX = 1u;
const uint kRightOfX = 2u;
const uint kRisingRight = 4u;

float cross2(vec2 a, vec2 b) { return a.x * b.y - a.y * b.x; }

float halfWidth(vec4 width, ivec2 leafCorner, vec2 anchor, float height) {
  vec2 xy = vec2(leafCorner - u_eyeCell) * u_cellSize - u_eyeRemainder + anchor;
  float distance = length(vec3(xy, height - u_eyeZ));
  return max(min(width.x * u_metresPerPixel * distance, width.z), width.y);
}

bool itemCovers(uint at, vec2 p, ivec2 leafCorner) {
  vec4 p0 = items[4u * at], p1 = items[4u * at + 1u], p2 = items[4u * at + 2u];
  uint header = floatBitsToUint(p0.w);
  uint kind = header & 3u;
  vec4 width = features[2u * (header >> 5u) + 1u];
  bool pixels = width.x > 0.0;
  vec2 a = p0.xy;
  if (kind == 0u) {  // segment
    vec2 d = p1.xy - a;
    float len = length(d);
    if (!(len > 0.0)) return false;
    vec2 u = d / len;
    float t = dot(p - a, u);
    if (t < 0.0 || t > len) return false;
    float h = p1.w;
    if (pixels) {
      float f0 = p0.z, f1 = p1.z;
      vec2 start = a + d * ((0.0 - f0) / (f1 - f0));
      vec2 end = a + d * ((1.0 - f0) / (f1 - f0));
      float h0 = halfWidth(width, leafCorner, start, p2.x);
      float h1 = halfWidth(width, leafCorner, end, p2.y);
      h = h0 + (h1 - h0) * (f0 + (f1 - f0) * t / len);
    }
    return abs(cross2(u, p - a)) <= h;
  }
  float s = pixels ? halfWidth(width, leafCorner, a, p2.x) : 1.0;
  if (kind == 1u) {  // band
    vec2 d = p - a;
    float t = dot(d, p1.xy);
    return t >= p0.z * s && t <= p1.z * s && abs(cross2(p1.xy, d)) <= p1.w * s;
  }
  if (kind == 2u) {  // disc
    vec2 d = p - a;
    float r = p0.z * s;
    return dot(d, d) <= r * r;
  }
  // convex, counter-clockwise offsets from the anchor
  vec4 p3 = items[4u * at + 3u];
  uint count = (header >> 2u) & 7u;
  vec2 q = p - a;
  vec2 o[4] = vec2[4](p1.xy * s, p1.zw * s, p3.xy * s, p3.zw * s);
  for (uint k = 0u; k < count; ++k) {
    vec2 e0 = o[k], e1 = o[(k + 1u) % count];
    if (cross2(e1 - e0, q - e0) < 0.0) return false;
  }
  return true;
}

bool groupCovers(uvec4 g, vec2 p, float yc) {
  bool inside = g.y != 0u;
  for (uint k = 0u; k < g.w; ++k) {
    vec4 ab = edges[2u * (g.z + k)];
    vec4 extra = edges[2u * (g.z + k) + 1u];
    uint flags = floatBitsToUint(extra.y);
    bool crosses = (flags & kCrossesX) != 0u;
    if ((ab.y > p.y) != (ab.w > p.y)) {
      float xi = ab.x + (p.y - ab.y) * (ab.z - ab.x) / (ab.w - ab.y);
      bool beyondP = xi > p.x;
      bool beyondX = crosses ? ((p.y >= extra.x) == ((flags & kRisingRight) != 0u)) : ((flags & kRightOfX) != 0u);
      if (beyondP != beyondX) inside = !inside;
    }
    if (crosses && ((extra.x > p.y) != (extra.x > yc))) inside = !inside;
  }
  return inside;
}

void main() {
  ivec2 texel = ivec2(gl_FragCoord.xy);
#ifdef MULTISAMPLE
  float depth = texelFetch(u_depth, texel, gl_SampleID).r;
  vec2 pixel = vec2(texel) + gl_SamplePosition;
#else
  float depth = texelFetch(u_depth, texel, 0).r;
  vec2 pixel = gl_FragCoord.xy;
#endif
  if (!(depth > 0.0)) discard;  // background
  vec4 h = u_inverse * vec4(2.0 * pixel / u_viewport - 1.0, depth, 1.0);
  vec3 rel = h.xyz / h.w;

  vec2 v = u_eyeRemainder + rel.xy;
  vec2 k = floor(v / u_cellSize);
  float cells = exp2(float(u_depthLevels));
  vec2 qf = vec2(u_eyeCell) + k;
  if (qf.x < 0.0 || qf.y < 0.0 || qf.x >= cells || qf.y >= cells) discard;
  ivec2 q = u_eyeCell + ivec2(k);
  vec2 r = v - k * u_cellSize;

  uint n = 0u;
  int level = 0;
  while (nodes[n].y == kInternal && level < 32) {
    int bit = u_depthLevels - 1 - level;
    n = nodes[n].x + uint((q.x >> bit) & 1) + 2u * uint((q.y >> bit) & 1);
    ++level;
  }
  uvec4 leaf = nodes[n];
  int shift = u_depthLevels - level;
  ivec2 corner = (q >> shift) << shift;
  vec2 p = vec2(q - corner) * u_cellSize + r;

  int feature = -1;
  for (uint i = 0u; i < leaf.y && feature < 0; ++i) {
    if (u_polygons != 0) {
      uvec4 g = groups[leaf.x + i];
      if (groupCovers(g, p, uintBitsToFloat(leaf.w))) feature = int(g.x);
    } else if (itemCovers(leaf.x + i, p, corner)) {
      feature = int(floatBitsToUint(items[4u * (leaf.x + i)].w) >> 5u);
    }
  }
  if (feature < 0) discard;
  vec4 c = features[2u * uint(feature)];
  o_color = vec4(c.rgb * c.a, c.a);
  o_mask = vec4(u_maskBit, 0.0, 0.0, 0.0);
}
