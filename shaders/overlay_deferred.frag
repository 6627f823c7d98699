#version 450 core
// The deferred technique (vector_overlay/src/deferred_index.hpp): per pixel (per sample with
// MULTISAMPLE), the terrain point from the depth buffer; for each layer in draw order, found in
// the layer's quadtree as integer cells plus a remainder (never as an absolute float position)
// and tested against what the leaf lists: polygons by the parity of a path inside the leaf,
// lines by the CPU reference's primitives. The layers' colours are composited here in order
// (premultiplied), as blending each over the last would; the mask gets each covering layer's
// bit. deferred_index.cpp's coveringFeature is this test on the CPU.
//
// A layer has an index per chart (vector_overlay/deferred_lookup.hpp): its frame's plane, or on
// the globe a face of the cube, each a header here; a pixel is looked up in the one header of
// each layer whose chart holds its ground point.
const int kMaxLayers = 112;  // headers (deferred_pass.cpp's kMaxHeaders)
struct Layer {
  uvec4 bases;  // nodes, entries (groups or items), edges, features: where the layer's arrays start
  uvec2 kind;   // 1: polygons, 0: lines, 2: lines in space (a face's); the finest level
  vec2 scale;   // mask bit, cell size at the finest level (metres)
  ivec2 eyeCell;  // the eye in cells of the finest level ...
  vec2 eyeRemainder;  // ... plus this (metres)
  uvec4 grid;  // where the layer's grid starts, its level, 1: widths in pixels, chart (0: plane, f + 1: face f)
  // A face: its middle direction, its x and y directions (the chart's), the eye relative to the
  // anchor (eyeCell and eyeRemainder are then the anchor's), the anchor's coordinates along the
  // three directions and the chart's scale; axis.w, east.w: the index's corner in the chart.
  vec4 axis;
  vec4 east;
  vec4 north;
  vec4 fromAnchor;
  vec4 anchorDots;
};
// A uniform block: the same for every pixel, read once per group of pixels, not per pixel.
layout(std140, binding = 1) uniform Layers {
  Layer layers[kMaxLayers];
};
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
layout(std430, binding = 10) readonly buffer Grid {
  uint grid[];  // per cell of a layer's grid: node | level << 27
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
uniform float u_eyeZ;
uniform vec3 u_eyeWorld;  // the eye, frame coordinates (the faces: which one a point lies in)
uniform vec3 u_radii;     // the faces' ellipsoid (a, a, b)
uniform float u_metresPerPixel;
uniform int u_layerCount;

layout(location = 0) out vec4 o_color;
layout(location = 1) out vec4 o_mask;

const uint kInternal = 0xFFFFFFFFu;
const uint kCrossesX = 1u;
const uint kRightOfX = 2u;
const uint kRisingRight = 4u;

float cross2(vec2 a, vec2 b) { return a.x * b.y - a.y * b.x; }

float halfWidth(Layer l, vec4 width, ivec2 leafCorner, vec2 anchor, float height) {
  vec2 xy = vec2(leafCorner - l.eyeCell) * l.scale.y - l.eyeRemainder + anchor;
  float distance = length(vec3(xy, height - u_eyeZ));
  return max(min(width.x * u_metresPerPixel * distance, width.z), width.y);
}

bool itemCovers(Layer l, uint at, vec2 p, ivec2 leafCorner) {
  vec4 p0 = items[4u * at], p1 = items[4u * at + 1u];
  uint header = floatBitsToUint(p0.w);
  uint kind = header & 3u;
  vec2 d = p - p0.xy;
  if (kind == 0u) {  // segment: the part [f0, f1] of the line's segment, from a along u
    float t = dot(d, p1.xy);
    if (t < 0.0 || t > p1.z) return false;
    float h = p1.w;
    vec4 width = l.grid.z != 0u ? features[2u * (l.bases.w + (header >> 5u)) + 1u] : vec4(0.0);
    if (width.x > 0.0) {
      vec4 p2 = items[4u * at + 2u];
      float f0 = p0.z, f1 = p2.z;
      float full = p1.z / (f1 - f0);
      float h0 = halfWidth(l, width, leafCorner, p0.xy - p1.xy * (f0 * full), p2.x);
      float h1 = halfWidth(l, width, leafCorner, p0.xy + p1.xy * ((1.0 - f0) * full), p2.y);
      h = h0 + (h1 - h0) * (f0 + t / full);
    }
    return abs(cross2(p1.xy, d)) <= h;
  }
  float s = 1.0;
  if (l.grid.z != 0u) {
    vec4 width = features[2u * (l.bases.w + (header >> 5u)) + 1u];
    if (width.x > 0.0) s = halfWidth(l, width, leafCorner, p0.xy, items[4u * at + 2u].x);
  }
  if (kind == 1u) {  // band
    float t = dot(d, p1.xy);
    return t >= p0.z * s && t <= p1.z * s && abs(cross2(p1.xy, d)) <= p1.w * s;
  }
  if (kind == 2u) {  // disc
    float r = p0.z * s;
    return dot(d, d) <= r * r;
  }
  // convex, counter-clockwise offsets from the anchor
  vec4 p3 = items[4u * at + 3u];
  uint count = (header >> 2u) & 7u;
  vec2 o[4] = vec2[4](p1.xy * s, p1.zw * s, p3.xy * s, p3.zw * s);
  for (uint k = 0u; k < count; ++k) {
    vec2 e0 = o[k], e1 = o[(k + 1u) % count];
    if (cross2(e1 - e0, d - e0) < 0.0) return false;
  }
  return true;
}

/// A leaf's point relative to its corner C on the ellipsoid, in space: F − C for the point F of
/// the ellipsoid at chart offset p from the corner (the inverse gnomonic map written as a
/// difference, every term a product of the small offset: precise near the eye, as p is), plus
/// `up`, the ground point's height along its normal. With d(u) = a + (e u.x + n u.y) / s and
/// t = 1 / sqrt(dᵀGd): F − C = t_F Δd + (t_F − t_C) d_C, t_F − t_C = t_F t_C (q_C − q_F) / (√q_C + √q_F).
/// `corner` gets C itself (float: what the ellipsoid's normals near it are found from).
vec3 fromLeafCorner(Layer l, ivec2 corner, vec2 p, vec3 up, out vec3 cornerPoint) {
  vec2 uC = vec2(l.axis.w, l.east.w) + vec2(corner) * l.scale.y;
  float s = l.anchorDots.w;
  vec3 g = 1.0 / (u_radii * u_radii);
  vec3 dC = l.axis.xyz + (l.east.xyz * uC.x + l.north.xyz * uC.y) / s;
  vec3 dd = (l.east.xyz * p.x + l.north.xyz * p.y) / s;
  vec3 dF = dC + dd;
  float qC = dot(dC * dC, g), qF = dot(dF * dF, g);
  float tC = inversesqrt(qC), tF = inversesqrt(qF);
  float qDiff = -dot((2.0 * dC + dd) * dd, g);  // q_C − q_F
  float dt = tF * tC * qDiff / (sqrt(qC) + sqrt(qF));
  cornerPoint = tC * dC;
  return tF * dd + dt * dC + up;
}

/// A line in pixels' half width at its anchor (relative to the leaf's corner), the eye being at
/// `eye` relative to it: its feature's rule (widthPixels / 2, least, largest), as in the plane.
float worldHalfWidth(vec4 width, vec3 anchor, vec3 eye) {
  return max(min(width.x * u_metresPerPixel * length(anchor - eye), width.z), width.y);
}

/// The ellipsoid's normal at a point near the leaf's corner (given relative to it).
vec3 normalNear(vec3 cornerPoint, vec3 fromCorner) {
  return normalize((cornerPoint + fromCorner) / (u_radii * u_radii));
}

/// A band's end at a point with normal n: the vertical plane through its side there (the globe
/// reference's, globe_detail.hpp bandEndNormal): its normal, pointing along the band u.
vec3 bandEndNormal(vec3 u, vec3 m, vec3 n) {
  vec3 side = normalize(m - n * dot(n, m));
  return u - side * dot(side, u) - n * dot(n, u);
}

/// Whether a primitive in space (deferred_index.hpp, buildWorld's layout) covers the point d
/// (relative to its leaf's corner, as are `eye` and the corner itself, `cornerPoint`): the globe
/// reference's cylinder around a disc's normal, its slab, or a join's prism; a line in pixels
/// with its half widths at its anchors.
bool worldItemCovers(Layer l, uint at, vec3 d, vec3 eye, vec3 cornerPoint) {
  vec4 p0 = items[4u * at];
  uint header = floatBitsToUint(p0.w);
  uint kind = header & 3u;
  if (kind == 3u) return true;  // the whole leaf
  bool pixels = (header & 4u) != 0u;
  vec4 width = pixels ? features[2u * (l.bases.w + (header >> 5u)) + 1u] : vec4(0.0);
  vec4 p1 = items[4u * at + 1u], p2 = items[4u * at + 2u];
  vec3 v = d - p0.xyz;
  if (kind == 2u) {  // disc: the cylinder around its normal
    float r = pixels ? worldHalfWidth(width, p0.xyz + p1.xyz * p2.x, eye) : p1.w;
    vec3 across = v - p1.xyz * dot(v, p1.xyz);
    return dot(across, across) <= r * r;
  }
  vec4 p3 = items[4u * at + 3u];
  if (kind == 1u) {  // band: the slab along its piece, between its ends' vertical planes
    vec3 b = p0.xyz + p1.xyz * p1.w;
    vec3 na = normalNear(cornerPoint, p0.xyz), nb = normalNear(cornerPoint, b);
    if (dot(v, bandEndNormal(p1.xyz, p2.xyz, na)) < 0.0 || dot(d - b, bandEndNormal(p1.xyz, p2.xyz, nb)) > 0.0)
      return false;
    float t = clamp(dot(v, p1.xyz), 0.0, p1.w);
    float r0 = p2.w, r1 = p3.x;
    if (pixels) {
      r0 = worldHalfWidth(width, p0.xyz + na * p3.y, eye);
      r1 = worldHalfWidth(width, b + nb * p3.z, eye);
    }
    return abs(dot(v, p2.xyz)) <= r0 + (r1 - r0) * (t / p1.w);
  }
  // convex: the corners in half widths in the plane square to the normal, counter-clockwise
  vec3 n = p1.xyz;
  vec3 e1 = normalize(cross(n, (header & 8u) != 0u ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 0.0, 1.0)));
  vec3 e2 = cross(n, e1);
  float r = pixels ? worldHalfWidth(width, p0.xyz + n * p1.w, eye) : p1.w;
  vec2 q = vec2(dot(v, e1), dot(v, e2));
  vec2 o[4] = vec2[4](p2.xy * r, p2.zw * r, p3.xy * r, p3.zw * r);
  for (uint k = 0u; k < 4u; ++k) {
    vec2 c0 = o[k], c1 = o[(k + 1u) % 4u];
    if (cross2(c1 - c0, q - c0) < 0.0) return false;
  }
  return true;
}

bool groupCovers(uint edgeBase, uvec4 g, vec2 p, float yc) {
  bool inside = g.y != 0u;
  for (uint k = 0u; k < g.w; ++k) {
    uint e = 2u * (edgeBase + g.z + k);
    vec4 ab = edges[e];
    vec4 extra = edges[e + 1u];
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

/// The first feature of layer l covering the point at `rel` (relative to the eye; on a face, its
/// offset from the anchor), or -1. `up`: the point's height along its normal, `fromEye` the point
/// relative to the eye (a face's lines in space).
int coveringFeature(Layer l, vec2 rel, vec3 up, vec3 fromEye) {
  vec2 v = l.eyeRemainder + rel;
  vec2 k = floor(v / l.scale.y);
  int levels = int(l.kind.y);
  float cells = exp2(float(levels));
  vec2 qf = vec2(l.eyeCell) + k;
  if (qf.x < 0.0 || qf.y < 0.0 || qf.x >= cells || qf.y >= cells) return -1;
  ivec2 q = l.eyeCell + ivec2(k);
  vec2 r = v - k * l.scale.y;
  int gridShift = levels - int(l.grid.y);
  uint cell = grid[l.grid.x + (uint(q.y >> gridShift) << l.grid.y) + uint(q.x >> gridShift)];
  uvec4 node = nodes[l.bases.x + (cell & 0x7FFFFFFu)];
  int level = int(cell >> 27u);
  while (node.y == kInternal && level < 32) {
    int bit = levels - 1 - level;
    node = nodes[l.bases.x + node.x + uint((q.x >> bit) & 1) + 2u * uint((q.y >> bit) & 1)];
    ++level;
  }
  if (node.y == 0u) return -1;
  int shift = levels - level;
  ivec2 corner = (q >> shift) << shift;
  vec2 p = vec2(q - corner) * l.scale.y + r;
  if (l.kind.x == 2u) {
    vec3 cornerPoint;
    vec3 d = fromLeafCorner(l, corner, p, up, cornerPoint);
    // The eye relative to the corner: the point's offsets from both (the depth's error in the
    // point is in both and leaves it).
    vec3 eye = d - fromEye;
    for (uint i = 0u; i < node.y; ++i) {
      uint at = l.bases.y + node.x + i;
      if (worldItemCovers(l, at, d, eye, cornerPoint)) return int(floatBitsToUint(items[4u * at].w) >> 5u);
    }
    return -1;
  }
  for (uint i = 0u; i < node.y; ++i) {
    if (l.kind.x != 0u) {
      uvec4 g = groups[l.bases.y + node.x + i];
      if (groupCovers(l.bases.z, g, p, uintBitsToFloat(node.w))) return int(g.x);
    } else if (itemCovers(l, l.bases.y + node.x + i, p, corner)) {
      return int(floatBitsToUint(items[4u * (l.bases.y + node.x + i)].w) >> 5u);
    }
  }
  return -1;
}

/// The cube face (0–5: +x, −x, +y, −y, +z, −z) a point lies in (DeferredChart::faceOf).
int faceOf(vec3 p) {
  vec3 a = abs(p);
  int axis = a.x >= a.y && a.x >= a.z ? 0 : (a.y >= a.z ? 1 : 2);
  return 2 * axis + (p[axis] < 0.0 ? 1 : 0);
}

/// A ground point's offset in face l's chart from the anchor's place there (DeferredChart::
/// ofGround): moved along the ellipsoid's normal by its height onto the ellipsoid, projected from
/// the centre. Written from the anchor, with small numbers only near the eye: f is the foot
/// relative to the anchor Q, and g(P) − g(Q) = s ((e·f)(a·Q) − (e·Q)(a·f)) / ((a·Q)(a·Q + a·f)).
vec2 faceOffset(Layer l, vec3 rel, vec3 up) {
  vec3 f = l.fromAnchor.xyz + rel - up;
  float aq = l.anchorDots.x;
  float af = dot(l.axis.xyz, f);
  vec2 num = vec2(dot(l.east.xyz, f), dot(l.north.xyz, f)) * aq - l.anchorDots.yz * af;
  return l.anchorDots.w * num / (aq * (aq + af));
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
  vec3 world = u_eyeWorld + rel;
  int face = faceOf(world);
  // The ground point's height along the ellipsoid's normal (the faces; found once, by the first
  // layer in a face): its foot is world − up.
  vec3 up = vec3(0.0);
  bool haveUp = false;

  vec4 color = vec4(0.0);  // premultiplied, the layers composited in order
  float mask = 0.0;
  for (int i = 0; i < u_layerCount; ++i) {
    Layer l = layers[i];
    vec2 at = rel.xy;
    if (l.grid.w != 0u) {
      if (l.grid.w != uint(face + 1)) continue;
      if (!haveUp) {
        vec3 gw = world / u_radii;
        up = length(world) * (1.0 - inversesqrt(dot(gw, gw))) * normalize(world / (u_radii * u_radii));
        haveUp = true;
      }
      at = faceOffset(l, rel, up);
    }
    int feature = coveringFeature(l, at, up, rel);
    if (feature < 0) continue;
    vec4 c = features[2u * (l.bases.w + uint(feature))];
    color = vec4(c.rgb * c.a, c.a) + (1.0 - c.a) * color;
    mask += l.scale.x;
  }
  if (mask == 0.0) discard;
  o_color = color;
  o_mask = vec4(mask, 0.0, 0.0, 0.0);
}
