#include "vector_overlay/overlay_renderer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "core/log.hpp"
#include "gfx/camera.hpp"
#include "screen_tiles.hpp"
#include "vector_overlay/stencil_states.hpp"

namespace gis::overlay {
namespace {

/// How many pieces of a layer's chunks may hold one point: per chunk, its own depth plus that of
/// every other chunk whose pieces' box meets its box (tiles of one level only touch; a parent
/// standing in, or lines drawn wider than their tile, overlap).
std::size_t chunkOverlap(std::span<const OverlayLayer* const> chunks) {
  std::size_t worst = 0;
  for (const OverlayLayer* a : chunks) {
    const auto [alo, ahi] = a->pieceBox();
    if (!(alo.x <= ahi.x)) continue;
    std::size_t depth = 0;
    for (const OverlayLayer* b : chunks) {
      const auto [blo, bhi] = b->pieceBox();
      // Boxes that only touch (tiles side by side, pieces clipped to them, up to rounding) share
      // no interior.
      const double e = 1e-6 * (1.0 + std::max({std::abs(alo.x), std::abs(alo.y), std::abs(ahi.x), std::abs(ahi.y)}));
      if (b == a ||
          (blo.x <= bhi.x && blo.x < ahi.x - e && alo.x < bhi.x - e && blo.y < ahi.y - e && alo.y < bhi.y - e))
        depth += b->maxOverlap();
    }
    worst = std::max(worst, depth);
  }
  return worst;
}

/// 0, 1, ..., n − 1: every z-fail piece of a classified layer (OverlayRenderer::drawZFail).
std::vector<std::size_t> firstIndices(std::size_t n) {
  std::vector<std::size_t> all(n);
  for (std::size_t k = 0; k < n; ++k) all[k] = k;
  return all;
}

/// Shader-storage binding of the cover rectangles (overlay_cover.vert).
constexpr GLuint kCoverRectsBinding = 3;

double distanceToBox(const glm::dvec3& p, const glm::dvec3& lo, const glm::dvec3& hi) {
  return glm::length(p - glm::clamp(p, lo, hi));
}

/// Normalised-device rectangle (x0, y0, x1, y1) holding the screen image of the box, clamped to
/// the viewport; the whole viewport when a corner lies near or behind the eye plane.
/// Bits of the depth buffer of framebuffer `fbo` when it is fixed point (unsigned normalised),
/// else 0 (float, or no depth buffer).
int fixedPointDepthBits(GLuint fbo) {
  const GLenum attachment = fbo == 0 ? GL_DEPTH : GL_DEPTH_ATTACHMENT;
  GLint objectType = GL_NONE;
  glGetNamedFramebufferAttachmentParameteriv(fbo, attachment, GL_FRAMEBUFFER_ATTACHMENT_OBJECT_TYPE, &objectType);
  if (objectType == GL_NONE) return 0;
  GLint componentType = GL_NONE, bits = 0;
  glGetNamedFramebufferAttachmentParameteriv(fbo, attachment, GL_FRAMEBUFFER_ATTACHMENT_COMPONENT_TYPE, &componentType);
  glGetNamedFramebufferAttachmentParameteriv(fbo, attachment, GL_FRAMEBUFFER_ATTACHMENT_DEPTH_SIZE, &bits);
  return componentType == GL_UNSIGNED_NORMALIZED ? bits : 0;
}

}  // namespace

Result<OverlayRenderer> OverlayRenderer::create() {
  Result<gfx::Program> program = gfx::Program::build({{"overlay_volume.vert", {}}, {"overlay_volume.frag", {}}});
  Result<gfx::Program> cover = gfx::Program::build({{"overlay_cover.vert", {}}, {"overlay_volume.frag", {}}});
  Result<gfx::Program> coverRects =
      gfx::Program::build({{"overlay_cover_rects.vert", {}}, {"overlay_volume.frag", {}}});
  Result<OverlayRenderer> r;
  r.diagnostics = program.diagnostics;
  r.diagnostics.append(cover.diagnostics);
  r.diagnostics.append(coverRects.diagnostics);
  if (!program || !cover || !coverRects) return r;
  OverlayRenderer renderer;
  renderer.program_ = std::move(*program);
  renderer.coverProgram_ = std::move(*cover);
  renderer.coverRectsProgram_ = std::move(*coverRects);
  renderer.emptyVao_ = gfx::createVertexArray();
  renderer.vao_ = gfx::createVertexArray();
  const GLuint vao = renderer.vao_.id();
  glEnableVertexArrayAttrib(vao, 0);
  glVertexArrayAttribFormat(vao, 0, 4, GL_FLOAT, GL_FALSE, 0);
  glVertexArrayAttribBinding(vao, 0, 0);
  glEnableVertexArrayAttrib(vao, 1);
  glVertexArrayAttribFormat(vao, 1, 4, GL_UNSIGNED_BYTE, GL_TRUE, 16);
  glVertexArrayAttribBinding(vao, 1, 0);
  glEnableVertexArrayAttrib(vao, 2);
  glVertexArrayAttribFormat(vao, 2, 3, GL_FLOAT, GL_FALSE, 0);
  glVertexArrayAttribBinding(vao, 2, 1);
  glVertexArrayBindingDivisor(vao, 1, 1);
  // Lines in pixels only (enabled per layer); disabled it reads (0, 0, 0): no offset.
  glVertexArrayAttribFormat(vao, 3, 4, GL_FLOAT, GL_FALSE, 0);
  glVertexArrayAttribBinding(vao, 3, 2);
  // World pieces only (enabled per layer, with u_alongNormals): the direction caps are padded along.
  glVertexArrayAttribFormat(vao, 4, 4, GL_FLOAT, GL_FALSE, 0);
  glVertexArrayAttribBinding(vao, 4, 3);
  renderer.timer_.emplace();
  renderer.coverTimer_.emplace();
  renderer.markStats_.emplace();
  renderer.coverStats_.emplace();
  r.value = std::move(renderer);
  return r;
}

void OverlayRenderer::drawRect(gfx::StateCache& cache, const glm::vec4& rect, const glm::vec4& colour, float maskBit) {
  if (!(rect.z > rect.x && rect.w > rect.y)) return;
  cache.useProgram(coverProgram_);
  coverProgram_.set("u_rect", rect);
  coverProgram_.set("u_color", colour);
  coverProgram_.set("u_maskBit", maskBit);
  cache.bindVertexArray(emptyVao_.id());
  glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
}

void OverlayRenderer::drawRects(gfx::StateCache& cache, const std::vector<glm::vec4>& rects, const glm::vec4& colour,
                                float maskBit) {
  if (rects.empty()) return;
  const std::size_t bytes = rects.size() * sizeof(glm::vec4);
  if (!rects_ || rectsCapacity_ < bytes) {
    rectsCapacity_ = std::max(bytes, 2 * rectsCapacity_);
    rects_ = gfx::createBuffer();
    glNamedBufferData(rects_.id(), static_cast<GLsizeiptr>(rectsCapacity_), nullptr, GL_STREAM_DRAW);
  }
  glNamedBufferSubData(rects_.id(), 0, static_cast<GLsizeiptr>(bytes), rects.data());
  cache.bindStorageBuffer(kCoverRectsBinding, rects_.id());
  cache.useProgram(coverRectsProgram_);
  coverRectsProgram_.set("u_color", colour);
  coverRectsProgram_.set("u_maskBit", maskBit);
  cache.bindVertexArray(emptyVao_.id());
  glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, static_cast<GLsizei>(rects.size()));
}

std::vector<glm::vec4> OverlayRenderer::tileRectsOf(const OverlayView& view, std::span<const Pieces> chunks) {
  ScreenTiles tiles(kCoverTiles);
  for (const Pieces& pieces : chunks)
    for (const auto& box : pieces.boxes) tiles.add(screenRect(view.viewProj, view.nearPlane, box[0], box[1]));
  return tiles.rects();
}

void OverlayRenderer::multiDraw(gfx::StateCache& cache, const std::vector<Command>& commands) {
  if (commands.empty()) return;
  const std::size_t bytes = commands.size() * sizeof(Command);
  if (!commands_ || commandsCapacity_ < bytes) {
    commandsCapacity_ = std::max(bytes, 2 * commandsCapacity_);
    commands_ = gfx::createBuffer();
    glNamedBufferData(commands_.id(), static_cast<GLsizeiptr>(commandsCapacity_), nullptr, GL_STREAM_DRAW);
  }
  glNamedBufferSubData(commands_.id(), 0, static_cast<GLsizeiptr>(bytes), commands.data());
  cache.useProgram(program_);
  cache.bindVertexArray(vao_.id());
  cache.bindIndirectBuffer(commands_.id());
  glMultiDrawElementsIndirect(GL_TRIANGLES, GL_UNSIGNED_INT, nullptr, static_cast<GLsizei>(commands.size()), 0);
}

void OverlayRenderer::drawZFail(gfx::StateCache& cache, const OverlayView& view, const OverlayLayer& layer,
                                const Pieces& pieces, std::span<const std::size_t> entries,
                                const gfx::PipelineState& state, const OverlaySettings& settings,
                                const PixelScale& scale, bool inPixels) {
  if (layer.geometry().footprintsReleased()) {
    std::vector<Command> whole;
    whole.reserve(entries.size());
    for (const std::size_t e : entries) whole.push_back(pieces.zFail[e]);
    cache.apply(state);
    multiDraw(cache, whole);
    return;
  }
  std::vector<std::size_t> slots;
  slots.reserve(entries.size());
  for (const std::size_t e : entries) slots.push_back(pieces.zFailSlots[e]);
  const GLsizei clipped = uploadClippedPieces(view, layer, slots, settings, scale);
  cache.apply(state);
  drawClipped(cache, layer, clipped, inPixels);
}

GLsizei OverlayRenderer::uploadClippedPieces(const OverlayView& view, const OverlayLayer& layer,
                                             const std::vector<std::size_t>& slots, const OverlaySettings& settings,
                                             const PixelScale& scale, bool capped) {
  if (slots.empty()) return 0;
  const CapPadding padding{settings.padBase, settings.padPerMetre, padPerMetreSquared_, layer.capReach()};
  const std::vector<ClippedVertex> out = clipAtNearPlane(view, layer.geometry(), slots, padding, scale, capped);
  const std::size_t bytes = out.size() * sizeof(ClippedVertex);
  if (bytes == 0) return 0;
  if (!clipped_ || clippedCapacity_ < bytes) {
    clippedCapacity_ = std::max(bytes, 2 * clippedCapacity_);
    clipped_ = gfx::createBuffer();
    glNamedBufferData(clipped_.id(), static_cast<GLsizeiptr>(clippedCapacity_), nullptr, GL_STREAM_DRAW);
  }
  glNamedBufferSubData(clipped_.id(), 0, static_cast<GLsizeiptr>(bytes), out.data());
  return static_cast<GLsizei>(out.size());
}

PixelScale OverlayRenderer::beginFrame(gfx::StateCache& cache, const OverlayView& view, const OverlaySettings& settings,
                                       std::span<const OverlayLayer* const> layers) {
  const gfx::DrawTarget target = cache.drawTarget();
  program_.set("u_modelViewProj", gfx::relativeToCentre(view.viewProj, view.eye));
  // A fixed-point depth buffer has steps that grow with the distance squared: pad beyond them.
  padPerMetreSquared_ = settings.padPerMetreSquared;
  if (const int bits = settings.padForDepthFormat ? fixedPointDepthBits(target.framebuffer) : 0;
      bits > 0 && view.nearPlane > 0.0) {
    padPerMetreSquared_ = std::max(padPerMetreSquared_, 2.0 / (view.nearPlane * std::ldexp(1.0, bits)));
    if (fixedDepthBitsLogged_ != bits) {
      fixedDepthBitsLogged_ = bits;
      logInfo("overlay: the depth buffer is " + std::to_string(bits) +
              "-bit fixed point; caps are padded by distance² / (near · 2^" + std::to_string(bits - 1) +
              ") as well. A float depth buffer (GL_DEPTH32F_STENCIL8) keeps them thin (docs/depth-precision.md)");
    }
  }
  program_.set("u_padBase", static_cast<float>(settings.padBase));
  program_.set("u_padPerMetre", static_cast<float>(settings.padPerMetre));
  program_.set("u_padPerMetreSquared", static_cast<float>(padPerMetreSquared_));
  // Lines in pixels need the size of a pixel: from the matrix and the viewport's height.
  PixelScale scale;
  if (std::any_of(layers.begin(), layers.end(), [](const OverlayLayer* l) { return l && l->widthPixels() > 0.0; })) {
    scale = pixelScaleOf(view.viewProj, target.viewport.height);
    scale.eye = view.eye;
  }
  return scale;
}

std::vector<LayerFrameStats> OverlayRenderer::draw(gfx::StateCache& cache, const OverlayView& view,
                                                   std::span<const OverlayLayer* const> layers,
                                                   const OverlaySettings& settings) {
  std::vector<LayerFrameStats> stats(layers.size());
  const PixelScale scale = beginFrame(cache, view, settings, layers);
  for (std::size_t i = 0; i < layers.size(); ++i) {
    if (layers[i] != nullptr) drawLayer(cache, view, layers.subspan(i, 1), i, settings, scale, stats[i]);
  }
  return stats;
}

std::vector<LayerFrameStats> OverlayRenderer::draw(gfx::StateCache& cache, const OverlayView& view,
                                                   std::span<const std::vector<const OverlayLayer*>> layers,
                                                   const OverlaySettings& settings) {
  std::vector<LayerFrameStats> stats(layers.size());
  std::vector<const OverlayLayer*> all;
  for (const auto& chunks : layers) all.insert(all.end(), chunks.begin(), chunks.end());
  const PixelScale scale = beginFrame(cache, view, settings, all);
  for (std::size_t i = 0; i < layers.size(); ++i) {
    if (!layers[i].empty()) drawLayer(cache, view, layers[i], i, settings, scale, stats[i]);
  }
  return stats;
}

bool OverlayRenderer::mayDrawZFail(const OverlayView& view, const OverlaySettings& settings, const glm::dvec3& lo,
                                   const glm::dvec3& hi) const {
  if (settings.forceZFail) return true;
  if (!(lo.x <= hi.x)) return false;  // no pieces
  // classify's margin, and the padding of any piece in the box: its distance plus diagonal is at
  // most the box's distance plus twice its diagonal. The quadratic term as the frame's, or as a
  // 24-bit depth buffer needs it if that is more (this may be asked before the frame begins).
  const double t = std::tan(view.fovYRadians / 2.0);
  const double margin = view.nearPlane * std::sqrt(1.0 + t * t * (1.0 + view.aspect * view.aspect)) + 0.01;
  const double d = distanceToBox(view.eye, lo, hi) + 2.0 * glm::length(hi - lo);
  const double quadratic = std::max({padPerMetreSquared_, settings.padPerMetreSquared,
                                     view.nearPlane > 0.0 ? 2.0 / (view.nearPlane * std::ldexp(1.0, 24)) : 0.0});
  const double pad = settings.padBase + settings.padPerMetre * d + quadratic * d * d;
  const glm::dvec3 grow(margin, margin, margin + pad);
  return distanceToBox(view.eye, lo - grow, hi + grow) <= 0.0;
}

OverlayRenderer::Pieces OverlayRenderer::classify(const OverlayView& view, const OverlayLayer& layer,
                                                  const OverlaySettings& settings, bool wholePieces,
                                                  LayerFrameStats& stats) const {
  Pieces out;
  const auto& slots = layer.slots();
  const auto& polyhedra = layer.polyhedra();
  if (slots.empty()) return out;
  const std::array<glm::dvec4, 6> planes = gfx::frustumPlanes(view.viewProj);
  // A polyhedron closer to the eye than the near plane's corners may be cut by it, or hold the
  // eye: it is drawn z-fail (exact for any eye position, with depth clamp and closed caps).
  const double t = std::tan(view.fovYRadians / 2.0);
  const double margin = view.nearPlane * std::sqrt(1.0 + t * t * (1.0 + view.aspect * view.aspect)) + 0.01;
  // World pieces' caps move along their normals: their boxes grow by the pad every way.
  const bool world = layer.alongNormals();
  for (const OverlayLayer::PieceSlot& s : slots) {
    if (!s.live) continue;
    const Polyhedron& p = polyhedra[static_cast<std::size_t>(&s - slots.data())];
    const double diagonal = glm::length(p.boxMax - p.boxMin) + (p.hi - p.lo);
    const glm::dvec3 lo0(p.boxMin, p.lo), hi0(p.boxMax, p.hi);
    const double pad = padAt(settings, distanceToBox(view.eye, lo0, hi0) + diagonal);
    const glm::dvec3 grow =
        world ? glm::dvec3(pad + std::max(layer.capReach().x, layer.capReach().y)) : glm::dvec3(0.0, 0.0, pad);
    const glm::dvec3 lo = lo0 - grow, hi = hi0 + grow;
    if (settings.cullPieces && !gfx::boxInFrustum(planes, lo, hi, false)) {
      ++stats.culledPieces;
      continue;
    }
    out.boxes.push_back({lo, hi});
    const bool fail = settings.forceZFail || (layer.paperVariant() || world ? distanceToBox(view.eye, lo, hi) <= margin
                                                                            : mayContain(p, view.eye, pad, margin));
    const Command whole{s.indexCount, 1, s.firstIndex, static_cast<GLint>(s.baseVertex), s.origin};
    if (fail) {
      ++stats.zFailPieces;
      out.zFail.push_back(whole);
      out.order.emplace_back(true, out.zFailSlots.size());
      out.zFailSlots.push_back(static_cast<std::size_t>(&s - slots.data()));
    } else {
      out.order.emplace_back(false, out.zPass.size());
      ++stats.zPassPieces;
      // Over drawn terrain the bottom cap is hidden from an eye outside: leave it out.
      const bool skipBottom = p.overSurface && !layer.paperVariant() && !wholePieces && !settings.bottomCapsInZPass;
      out.zPass.push_back(skipBottom ? Command{s.indexCount - s.bottomCount, 1, s.firstIndex + s.bottomCount,
                                               static_cast<GLint>(s.baseVertex), s.origin}
                                     : whole);
    }
    if (layer.paperVariant()) {
      const Command box{36, 1, s.boxFirstIndex, static_cast<GLint>(s.baseVertex), s.origin};
      (fail ? out.coverZFail : out.coverZPass).push_back(box);
    }
  }
  return out;
}

glm::vec4 OverlayRenderer::rectOf(const OverlayView& view, const Pieces& pieces, std::size_t first, std::size_t last) {
  if (first >= last) return glm::vec4(0.0F);
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (std::size_t k = first; k < last; ++k) {
    lo = glm::min(lo, pieces.boxes[k][0]);
    hi = glm::max(hi, pieces.boxes[k][1]);
  }
  return screenRect(view.viewProj, view.nearPlane, lo, hi);
}

bool OverlayRenderer::bindLayer(const OverlayView& view, const OverlayLayer& layer, const PixelScale& scale) {
  // Origins relative to the eye, in the order of the layer's origin table, then a zero origin
  // for geometry already relative to the eye (the clipped pieces).
  const auto& origins = layer.origins();
  const auto& worldOrigins = layer.geometry().worldOrigins();
  std::vector<float> offsets;
  offsets.reserve(3 * (origins.size() + worldOrigins.size()) + 3);
  for (const glm::dvec2& o : origins) {
    offsets.insert(offsets.end(), {static_cast<float>(o.x - view.eye.x), static_cast<float>(o.y - view.eye.y),
                                   static_cast<float>(-view.eye.z)});
  }
  for (const glm::dvec3& o : worldOrigins) {
    const glm::dvec3 d = o - view.eye;
    offsets.insert(offsets.end(), {static_cast<float>(d.x), static_cast<float>(d.y), static_cast<float>(d.z)});
  }
  offsets.insert(offsets.end(), {0.0F, 0.0F, 0.0F});
  const std::size_t bytes = offsets.size() * sizeof(float);
  if (!origins_ || originsCapacity_ < bytes) {
    originsCapacity_ = std::max(bytes, 2 * originsCapacity_);
    origins_ = gfx::createBuffer();
    glNamedBufferData(origins_.id(), static_cast<GLsizeiptr>(originsCapacity_), nullptr, GL_STREAM_DRAW);
  }
  glNamedBufferSubData(origins_.id(), 0, static_cast<GLsizeiptr>(bytes), offsets.data());
  const GLuint vao = vao_.id();
  glVertexArrayVertexBuffer(vao, 0, layer.vertexBuffer(), 0, 20);
  glVertexArrayVertexBuffer(vao, 1, origins_.id(), 0, 3 * sizeof(float));
  glVertexArrayElementBuffer(vao, layer.indexBuffer());
  boundAlongNormals_ = layer.alongNormals() && layer.normalBuffer() != 0;
  if (boundAlongNormals_) {
    glVertexArrayVertexBuffer(vao, 3, layer.normalBuffer(), 0, 4 * sizeof(float));
    glEnableVertexArrayAttrib(vao, 4);
    program_.set("u_alongNormals", 1);
    program_.set("u_capReach", glm::vec2(layer.capReach()));
  }
  const bool inPixels = layer.widthPixels() > 0.0 && layer.scalingBuffer() != 0;
  if (inPixels) {
    glVertexArrayVertexBuffer(vao, 2, layer.scalingBuffer(), 0, 4 * sizeof(float));
    glEnableVertexArrayAttrib(vao, 3);
    program_.set("u_halfWidthPerMetre", static_cast<float>(0.5 * layer.widthPixels() * scale.metresPerPixel));
    program_.set("u_maxHalfWidth", static_cast<float>(0.5 * layer.style().widthCap()));
  }
  return inPixels;
}

void OverlayRenderer::endLayer(bool inPixels) {
  if (inPixels) glDisableVertexArrayAttrib(vao_.id(), 3);
  if (boundAlongNormals_) {
    glDisableVertexArrayAttrib(vao_.id(), 4);
    program_.set("u_alongNormals", 0);
    boundAlongNormals_ = false;
  }
}

void OverlayRenderer::drawClipped(gfx::StateCache& cache, const OverlayLayer& layer, GLsizei vertices, bool inPixels) {
  if (vertices == 0) return;
  const GLuint vao = vao_.id();
  cache.useProgram(program_);
  cache.bindVertexArray(vao);
  glVertexArrayVertexBuffer(vao, 0, clipped_.id(), 0, 20);
  if (inPixels) glDisableVertexArrayAttrib(vao, 3);  // already at this frame's width
  // World pieces' caps are already padded along their normals and moved by their reach: the
  // normal reads (0, 0, 0, 1) and moves nothing.
  if (boundAlongNormals_) glDisableVertexArrayAttrib(vao, 4);
  const auto zeroOrigin = static_cast<GLuint>(layer.origins().size() + layer.geometry().worldOrigins().size());
  glDrawArraysInstancedBaseInstance(GL_TRIANGLES, 0, vertices, 1, zeroOrigin);
  if (boundAlongNormals_) glEnableVertexArrayAttrib(vao, 4);
  if (inPixels) glEnableVertexArrayAttrib(vao, 3);
  glVertexArrayVertexBuffer(vao, 0, layer.vertexBuffer(), 0, 20);
}

void OverlayRenderer::beginMeasure(const OverlaySettings& settings) {
  if (!settings.measure) return;
  timer_->begin();
  markStats_->begin();
}

void OverlayRenderer::endMeasure(const OverlaySettings& settings, double& milliseconds, std::uint64_t& fragments) {
  if (!settings.measure) return;
  markStats_->end();
  timer_->end();
  milliseconds = static_cast<double>(timer_->nanoseconds().value_or(0)) * 1e-6;
  fragments = markStats_->result().fragmentShaderInvocations;
}

void OverlayRenderer::switchToCover(const OverlaySettings& settings) {
  if (!settings.measure) return;
  markStats_->end();
  timer_->end();
  coverStats_->begin();
  coverTimer_->begin();
}

void OverlayRenderer::markIntoFlag(gfx::StateCache& cache, const OverlayView& view, const OverlayLayer& layer,
                                   const Pieces& pieces, const OverlaySettings& settings, const PixelScale& scale,
                                   bool inPixels, const FlagMarkStates& states, LayerFrameStats& stats) {
  const std::size_t n = pieces.order.size();
  for (std::size_t first = 0; first < n; first += states.groupSize) {
    const std::size_t last = std::min(n, first + states.groupSize);
    std::vector<Command> groupPass;
    std::vector<std::size_t> groupFail;
    for (std::size_t k = first; k < last; ++k) {
      if (pieces.order[k].first) {
        groupFail.push_back(pieces.order[k].second);
      } else {
        groupPass.push_back(pieces.zPass[pieces.order[k].second]);
      }
    }
    cache.apply(states.markZPass);
    multiDraw(cache, groupPass);
    drawZFail(cache, view, layer, pieces, groupFail, states.markZFail, settings, scale, inPixels);
    cache.apply(states.collect);
    drawRect(cache, rectOf(view, pieces, first, last), glm::vec4(0.0F), 0.0F);
    ++stats.groups;
  }
}

void OverlayRenderer::drawLayer(gfx::StateCache& cache, const OverlayView& view,
                                std::span<const OverlayLayer* const> chunks, std::size_t index,
                                const OverlaySettings& settings, const PixelScale& scale, LayerFrameStats& stats) {
  // The chunks of one layer (one, or its tiles) are marked one after the other into the same
  // counts and covered once: pieces of different chunks may overlap (a tile and the parent
  // drawn while it builds), and a pixel inside any of them is coloured once.
  std::vector<Pieces> pieces;
  pieces.reserve(chunks.size());
  std::size_t total = 0;
  bool paper = false;
  std::optional<glm::vec4> uniform;
  bool uniformKnown = false, mixed = false;
  for (const OverlayLayer* chunk : chunks) {
    pieces.push_back(classify(view, *chunk, settings, false, stats));
    total += pieces.back().order.size();
    paper = paper || chunk->paperVariant();
    if (pieces.back().order.empty()) continue;
    const std::optional<glm::vec4> u = chunk->uniformColor();
    if (!uniformKnown) {
      uniform = u;
      uniformKnown = true;
    } else if (u != uniform) {
      mixed = true;
    }
  }
  const std::optional<glm::vec4> rectColour = paper || !settings.rectangleCover || mixed ? std::nullopt : uniform;
  stats.rectangleCover = rectColour.has_value();
  for (Pieces& p : pieces) {
    if (!paper && !rectColour) {
      p.coverZPass = p.zPass;
      p.coverZFail = p.zFail;
    }
    stats.drawCommands += p.zPass.size() + p.zFail.size() + p.coverZPass.size() + p.coverZFail.size();
  }
  if (total == 0) return;
  const float maskBit = static_cast<float>(std::uint32_t{1} << std::min<std::size_t>(index, 23));
  std::vector<glm::vec4> rects;
  if (rectColour && settings.tiledCover) {
    rects = tileRectsOf(view, pieces);
  } else {
    glm::vec4 rect(1.0F, 1.0F, -1.0F, -1.0F);
    for (const Pieces& p : pieces) {
      if (p.order.empty()) continue;
      const glm::vec4 r = rectOf(view, p, 0, p.order.size());
      rect =
          glm::vec4(glm::min(glm::vec2(rect), glm::vec2(r)), glm::max(glm::vec2(rect.z, rect.w), glm::vec2(r.z, r.w)));
    }
    rects.push_back(rect);
  }

  const bool grouped = !paper && (settings.forceGroups || chunkOverlap(chunks) > 255);
  stats.grouped = grouped;
  beginMeasure(settings);
  program_.set("u_maskBit", maskBit);
  if (paper) {
    // The seed paper's construction: marked with its own states, covered by the pieces' boxes
    // (one chunk in a projected frame, the tiles of a globe layer), every chunk marked before any
    // is covered.
    for (std::size_t c = 0; c < chunks.size(); ++c) {
      const Pieces& p = pieces[c];
      if (p.order.empty()) continue;
      const bool inPixels = bindLayer(view, *chunks[c], scale);
      cache.apply(kPaperMarkZPassFront);
      multiDraw(cache, p.zPass);
      cache.apply(kPaperMarkZPassBack);
      multiDraw(cache, p.zPass);
      cache.apply(kPaperMarkZFailBack);
      multiDraw(cache, p.zFail);
      cache.apply(kPaperMarkZFailFront);
      multiDraw(cache, p.zFail);
      endLayer(inPixels);
    }
    switchToCover(settings);
    for (std::size_t c = 0; c < chunks.size(); ++c) {
      const Pieces& p = pieces[c];
      if (p.order.empty()) continue;
      const bool inPixels = bindLayer(view, *chunks[c], scale);
      cache.apply(kPaperCoverZPass);
      multiDraw(cache, p.coverZPass);
      cache.apply(kPaperCoverZFail);
      multiDraw(cache, p.coverZFail);
      endLayer(inPixels);
    }
  } else {
    // Mark every chunk (in groups into the flag when the counts could reach 256).
    for (std::size_t c = 0; c < chunks.size(); ++c) {
      if (pieces[c].order.empty()) continue;
      const bool inPixels = bindLayer(view, *chunks[c], scale);
      if (grouped) {
        markIntoFlag(cache, view, *chunks[c], pieces[c], settings, scale, inPixels, kGroupedMark, stats);
      } else {
        cache.apply(kMarkZPass);
        multiDraw(cache, pieces[c].zPass);
        drawZFail(cache, view, *chunks[c], pieces[c], firstIndices(pieces[c].zFailSlots.size()), kMarkZFail, settings,
                  scale, inPixels);
      }
      endLayer(inPixels);
    }
    switchToCover(settings);
    if (rectColour) {
      cache.apply(grouped ? kCoverFlaggedRect : kCoverRect);
      drawRects(cache, rects, *rectColour, maskBit);
    } else {
      // Each chunk's pieces, front faces (z-pass) or back faces (z-fail), where marked.
      for (std::size_t c = 0; c < chunks.size(); ++c) {
        if (pieces[c].order.empty()) continue;
        const bool inPixels = bindLayer(view, *chunks[c], scale);
        cache.apply(grouped ? kCoverFlaggedZPass : kCoverZPass);
        multiDraw(cache, pieces[c].zPass);
        drawZFail(cache, view, *chunks[c], pieces[c], firstIndices(pieces[c].zFailSlots.size()),
                  grouped ? kCoverFlaggedZFail : kCoverZFail, settings, scale, inPixels);
        endLayer(inPixels);
      }
    }
  }
  if (settings.measure) {
    coverStats_->end();
    coverTimer_->end();
    stats.markMilliseconds = static_cast<double>(timer_->nanoseconds().value_or(0)) * 1e-6;
    stats.coverMilliseconds = static_cast<double>(coverTimer_->nanoseconds().value_or(0)) * 1e-6;
    stats.gpuMilliseconds = stats.markMilliseconds + stats.coverMilliseconds;
    const gfx::PipelineCounts mark = markStats_->result(), cover = coverStats_->result();
    stats.markFragments = mark.fragmentShaderInvocations;
    stats.coverFragments = cover.fragmentShaderInvocations;
    stats.markTriangles = mark.primitivesSubmitted;
    stats.coverTriangles = cover.primitivesSubmitted;
  }
}

}  // namespace gis::overlay
