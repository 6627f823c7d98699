// The deferred per-pixel technique: no polyhedra and no stencil. Per layer a quadtree index
// of its polygons' edges and its lines' primitives (deferred_index.hpp) in shader storage, and
// one pass over the screen tiles the layer's content can project to: each pixel (each sample
// with MSAA) reads the terrain's depth, finds its ground point in the index and is coloured
// when a feature covers it (the first covering feature's colour), adding the layer's bit to the
// mask. Cost grows with pixels × entries per leaf, not with triangles.
//
// The depth is read from a copy of the target's depth buffer (a blit per frame), so any
// framebuffer, the default one included, can be drawn into.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <unordered_map>

#include <glm/gtc/matrix_transform.hpp>
#include "../deferred_index.hpp"
#include "../screen_tiles.hpp"

#include "gfx/program.hpp"
#include "gfx/queries.hpp"
#include "techniques/techniques.hpp"

namespace gis::overlay {
namespace {

constexpr GLuint kRectsBinding = 3;  // overlay_cover_rects.vert
constexpr GLuint kLayersBinding =
    1;  // overlay_deferred.frag (a uniform block of kMaxLayers: 16 KB, the least GL allows)
constexpr std::size_t kMaxLayers = 256;
constexpr GLuint kNodesBinding = 4;
constexpr GLuint kGroupsBinding = 5;
constexpr GLuint kEdgesBinding = 6;
constexpr GLuint kItemsBinding = 7;
constexpr GLuint kFeaturesBinding = 8;
constexpr GLuint kGridBinding = 10;
constexpr GLuint kDepthUnit = 0;
constexpr int kScreenTiles = 32;

/// The depth buffer of a framebuffer as a texture can hold a copy of it.
struct DepthFormat {
  GLenum internalFormat = GL_DEPTH32F_STENCIL8;
  int samples = 0;
  bool operator==(const DepthFormat&) const = default;
};

DepthFormat depthFormatOf(GLuint framebuffer) {
  DepthFormat f;
  GLint samples = 0;
  glGetNamedFramebufferParameteriv(framebuffer, GL_SAMPLES, &samples);
  f.samples = samples > 1 ? samples : 0;
  const GLenum attachment = framebuffer == 0 ? GL_DEPTH : GL_DEPTH_ATTACHMENT;
  GLint bits = 0, type = 0, stencil = 0;
  glGetNamedFramebufferAttachmentParameteriv(framebuffer, attachment, GL_FRAMEBUFFER_ATTACHMENT_DEPTH_SIZE, &bits);
  glGetNamedFramebufferAttachmentParameteriv(framebuffer, attachment, GL_FRAMEBUFFER_ATTACHMENT_COMPONENT_TYPE, &type);
  glGetNamedFramebufferAttachmentParameteriv(framebuffer, framebuffer == 0 ? GL_STENCIL : GL_STENCIL_ATTACHMENT,
                                             GL_FRAMEBUFFER_ATTACHMENT_STENCIL_SIZE, &stencil);
  if (type == GL_FLOAT) {
    f.internalFormat = stencil > 0 ? GL_DEPTH32F_STENCIL8 : GL_DEPTH_COMPONENT32F;
  } else if (bits >= 32) {
    f.internalFormat = GL_DEPTH_COMPONENT32;
  } else if (bits >= 24) {
    f.internalFormat = stencil > 0 ? GL_DEPTH24_STENCIL8 : GL_DEPTH_COMPONENT24;
  } else {
    f.internalFormat = GL_DEPTH_COMPONENT16;
  }
  return f;
}

/// The target's depth as a texture the pass can read: the target's own depth texture when it
/// has one (the pass neither tests nor writes depth, so reading the attachment is no feedback
/// loop), else a copy (a blit per frame: the default framebuffer, renderbuffers).
class DepthSource {
 public:
  GLuint texture(const DrawTarget& target) {
    GLint type = GL_NONE, name = 0;
    if (target.framebuffer != 0) {
      glGetNamedFramebufferAttachmentParameteriv(target.framebuffer, GL_DEPTH_ATTACHMENT,
                                                 GL_FRAMEBUFFER_ATTACHMENT_OBJECT_TYPE, &type);
      glGetNamedFramebufferAttachmentParameteriv(target.framebuffer, GL_DEPTH_ATTACHMENT,
                                                 GL_FRAMEBUFFER_ATTACHMENT_OBJECT_NAME, &name);
    }
    GLint samples = 0;
    glGetNamedFramebufferParameteriv(target.framebuffer, GL_SAMPLES, &samples);
    multisampled_ = samples > 1;
    if (type == GL_TEXTURE && name != 0) return static_cast<GLuint>(name);
    return copy(target);
  }
  [[nodiscard]] bool multisampled() const { return multisampled_; }
  [[nodiscard]] std::size_t bytes() const {
    return static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_) *
           static_cast<std::size_t>(std::max(1, format_.samples)) * 8;
  }

 private:
  GLuint copy(const DrawTarget& target) {
    const DepthFormat format = depthFormatOf(target.framebuffer);
    if (!texture_ || format != format_ || width_ != target.width || height_ != target.height) {
      format_ = format;
      width_ = target.width;
      height_ = target.height;
      texture_ = gfx::createTexture(format.samples > 0 ? GL_TEXTURE_2D_MULTISAMPLE : GL_TEXTURE_2D);
      if (format.samples > 0) {
        glTextureStorage2DMultisample(texture_.id(), format.samples, format.internalFormat, width_, height_, GL_TRUE);
      } else {
        glTextureStorage2D(texture_.id(), 1, format.internalFormat, width_, height_);
        glTextureParameteri(texture_.id(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        glTextureParameteri(texture_.id(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
      }
      const bool stencil =
          format.internalFormat == GL_DEPTH32F_STENCIL8 || format.internalFormat == GL_DEPTH24_STENCIL8;
      framebuffer_ = gfx::createFramebuffer();
      glNamedFramebufferTexture(framebuffer_.id(), stencil ? GL_DEPTH_STENCIL_ATTACHMENT : GL_DEPTH_ATTACHMENT,
                                texture_.id(), 0);
      glNamedFramebufferDrawBuffer(framebuffer_.id(), GL_NONE);
      glNamedFramebufferReadBuffer(framebuffer_.id(), GL_NONE);
    }
    glBlitNamedFramebuffer(target.framebuffer, framebuffer_.id(), 0, 0, width_, height_, 0, 0, width_, height_,
                           GL_DEPTH_BUFFER_BIT, GL_NEAREST);
    return texture_.id();
  }

  bool multisampled_ = false;
  DepthFormat format_;
  int width_ = 0, height_ = 0;
  gfx::TextureHandle texture_;
  gfx::FramebufferHandle framebuffer_;
};

/// A layer's index, with its cover boxes at the terrain's heights.
struct LayerIndex {
  deferred::Index index;
  std::vector<std::array<glm::dvec3, 2>> cover;
};

/// Per drawn layer, what the shader reads of it (std430, overlay_deferred.frag's Layer).
struct LayerHeader {
  std::uint32_t nodeBase = 0, entryBase = 0, edgeBase = 0, featureBase = 0;
  std::uint32_t polygons = 0, depth = 0;
  float maskBit = 0.0F, cellSize = 0.0F;
  std::int32_t eyeCellX = 0, eyeCellY = 0;
  float eyeRemainderX = 0.0F, eyeRemainderY = 0.0F;
  std::uint32_t gridBase = 0, gridLevel = 0, inPixels = 0, pad = 0;
};
static_assert(sizeof(LayerHeader) == 64);

/// A layer's index at a reach class: -1 for lines binned at their own largest width (or none in
/// pixels), c ≥ 0 for lines in pixels binned at DeferredLookup's base reach × 2^c.
using IndexKey = std::pair<const OverlayLayer*, int>;

struct IndexKeyHash {
  std::size_t operator()(const IndexKey& k) const {
    return std::hash<const void*>()(k.first) ^ (std::hash<int>()(k.second) << 1U);
  }
};

constexpr int kNaturalReach = -1;
constexpr int kLargestReachClass = 12;  ///< base × 4096
constexpr int kNoReach = 1000;          ///< wider than every class

/// The indices of the layers drawn, one after another in shared buffers.
struct Arena {
  std::vector<IndexKey> layers;      ///< in the order their arrays are laid out
  std::vector<LayerHeader> headers;  ///< their offsets (per-frame fields filled at draw)
  gfx::BufferHandle nodes, groups, edges, items, features, grid;
  std::size_t bytes = 0;
};

template <typename T>
void append(std::vector<std::uint8_t>& out, const std::vector<T>& data) {
  const auto* p = reinterpret_cast<const std::uint8_t*>(data.data());
  out.insert(out.end(), p, p + data.size() * sizeof(T));
}

gfx::BufferHandle bufferOf(std::vector<std::uint8_t> bytes) {
  bytes.resize(std::max<std::size_t>(bytes.size(), 16), 0);  // binding a zero-sized range is an error
  return gfx::createBufferWithData(bytes.data(), bytes.size());
}

class DeferredTechnique final : public DeferredLookup {
 public:
  DeferredTechnique(gfx::Program single, gfx::Program multi, const HeightBoundsProvider* bounds, double maxReach,
                    std::optional<std::array<glm::dvec2, 2>> region)
      : maxReach_(maxReach),
        region_(region),
        single_(std::move(single)),
        multi_(std::move(multi)),
        bounds_(bounds),
        vao_(gfx::createVertexArray()),
        rects_(gfx::createBuffer()),
        headers_(gfx::createBuffer()) {}

  void drawFrame(gfx::StateCache& cache, const TechniqueFrame& frame, TechniqueFrameStats& stats) override {
    stats.layers.assign(frame.layers.size(), LayerFrameStats{});
    lastLayers_.assign(frame.layers.begin(), frame.layers.end());
    const OverlayView& view = frame.view;
    // Every layer drawn in one pass: one depth read and reconstruction per pixel, the layers
    // composited in order in the shader (as one blend of each over the last would give).
    std::vector<IndexKey> keys(frame.layers.size(), IndexKey{nullptr, kNaturalReach});
    for (std::size_t i = 0; i < frame.layers.size(); ++i) {
      if (frame.layers[i] == nullptr) continue;
      // A view wider than every class (auto would not have chosen it) draws with the widest.
      keys[i] = {frame.layers[i],
                 std::min(reachClass(*frame.layers[i], view, frame.target.height), kLargestReachClass)};
    }
    ensureArena(keys);
    ScreenTiles tiles(kScreenTiles);
    std::vector<LayerHeader> headers;
    std::optional<std::size_t> first;
    for (std::size_t i = 0; i < frame.layers.size(); ++i) {
      const OverlayLayer* layer = frame.layers[i];
      if (layer == nullptr) continue;
      const LayerIndex& li = layers_.at(keys[i]);
      if (li.index.empty()) continue;
      bool onScreen = false;
      for (const auto& box : li.cover) {
        const glm::vec4 r = screenRect(view.viewProj, view.nearPlane, box[0], box[1]);
        onScreen = onScreen || (r.z >= r.x && r.w >= r.y);
        tiles.add(r);
      }
      if (!onScreen) continue;
      LayerHeader h = arena_.headers[arenaSlot_.at(keys[i])];
      const deferred::EyeCells eye = deferred::eyeCells(li.index, view.eye);
      h.eyeCellX = eye.cell.x;
      h.eyeCellY = eye.cell.y;
      h.eyeRemainderX = eye.remainder.x;
      h.eyeRemainderY = eye.remainder.y;
      h.maskBit = static_cast<float>(std::uint32_t{1} << std::min<std::size_t>(i, 23));
      headers.push_back(h);
      stats.layers[i].rectangleCover = true;
      if (!first) first = i;
    }
    const std::vector<glm::vec4> rects = tiles.rects();
    if (headers.empty() || rects.empty()) return;
    LayerFrameStats& s = stats.layers[*first];
    s.drawCommands = 1;

    const GLuint depth = depth_.texture(frame.target);
    gfx::Program& program = depth_.multisampled() ? multi_ : single_;
    cache.useProgram(program);
    cache.bindTexture(kDepthUnit, depth);
    cache.bindVertexArray(vao_.id());
    gfx::PipelineState state;
    state.depth.test = false;
    state.depth.write = false;
    state.blend = gfx::kBlendPremultipliedOver;
    state.raster.cull = gfx::CullMode::None;
    cache.apply(state);
    const glm::dmat4 relative = view.viewProj * glm::translate(glm::dmat4(1.0), view.eye);
    program.set("u_depth", static_cast<int>(kDepthUnit));
    program.set("u_inverse", glm::mat4(glm::inverse(relative)));
    program.set("u_viewport", glm::vec2(frame.target.width, frame.target.height));
    program.set("u_eyeZ", static_cast<float>(view.eye.z));
    program.set("u_metresPerPixel",
                static_cast<float>(pixelScaleOf(view.viewProj, frame.target.height).metresPerPixel));
    upload(rects_, rectsCapacity_, rects.data(), rects.size() * sizeof(glm::vec4));
    cache.bindStorageBuffer(kRectsBinding, rects_.id());
    cache.bindStorageBuffer(kNodesBinding, arena_.nodes.id());
    cache.bindStorageBuffer(kGroupsBinding, arena_.groups.id());
    cache.bindStorageBuffer(kEdgesBinding, arena_.edges.id());
    cache.bindStorageBuffer(kItemsBinding, arena_.items.id());
    cache.bindStorageBuffer(kFeaturesBinding, arena_.features.id());
    cache.bindStorageBuffer(kGridBinding, arena_.grid.id());
    if (frame.settings.measure) {
      timer_.begin();
      statistics_.begin();
    }
    // The uniform block holds kMaxLayers layers: more are drawn in further passes, each
    // blended over the last (the same as one pass).
    for (std::size_t batch = 0; batch < headers.size(); batch += kMaxLayers) {
      const std::size_t count = std::min(kMaxLayers, headers.size() - batch);
      std::vector<LayerHeader> block(kMaxLayers);
      std::copy_n(headers.begin() + static_cast<std::ptrdiff_t>(batch), count, block.begin());
      upload(headers_, headersCapacity_, block.data(), block.size() * sizeof(LayerHeader));
      cache.bindUniformBuffer(kLayersBinding, headers_.id());
      program.set("u_layerCount", static_cast<int>(count));
      glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, static_cast<GLsizei>(rects.size()));
    }
    if (frame.settings.measure) {
      statistics_.end();
      timer_.end();
      s.coverMilliseconds = static_cast<double>(timer_.nanoseconds().value_or(0)) * 1e-6;
      s.gpuMilliseconds = s.coverMilliseconds;
      const gfx::PipelineCounts counts = statistics_.result();
      s.coverFragments = counts.fragmentShaderInvocations;
      s.coverTriangles = counts.primitivesSubmitted;
    }
  }

  void invalidate() override { dropAll(); }
  void invalidate(const glm::dvec2& lo, const glm::dvec2& hi) override {
    (void)lo;
    (void)hi;
    dropAll();
  }
  void featureChanged(std::size_t layer, std::size_t feature, const glm::dvec2& lo, const glm::dvec2& hi) override {
    // That layer's index is made again at the next frame, from its features as they are then.
    (void)feature;
    if (layer >= lastLayers_.size() || lastLayers_[layer] == nullptr) return invalidate(lo, hi);
    const OverlayLayer* changed = lastLayers_[layer];
    reach_.erase(changed);
    std::erase_if(layers_, [changed](const auto& entry) { return entry.first.first == changed; });
    arena_.layers.clear();  // laid out again
  }
  [[nodiscard]] std::size_t gpuBytes() const override { return depth_.bytes() + arena_.bytes; }

  [[nodiscard]] bool canDraw(const OverlayLayer& layer, const OverlayView& view, int height,
                             std::size_t maxIndexBytes) override {
    const int c = reachClass(layer, view, height);
    if (c == kNoReach) return false;
    const auto built = layers_.find({&layer, c});
    if (built != layers_.end()) return built->second.index.bytes() <= maxIndexBytes;
    return reachInfo(layer).estimatedBytes <= maxIndexBytes;
  }

 private:
  /// What canDraw needs of a layer, found once.
  struct LayerReach {
    bool pixels = false;  ///< some line's widths are in pixels
    double pixelsHalf = 0.0, leastHalf = 0.0, largestHalf = 0.0;
    glm::dvec3 lo{0.0}, hi{0.0};  ///< the layer's extent, with the terrain's heights
    std::size_t estimatedBytes = 0;

    /// The widest half width the layer's lines can take in this view: the farthest corner of its
    /// extent bounds the distance of every vertex.
    [[nodiscard]] double widestHalf(const OverlayView& view, int height) const {
      double far = 0.0;
      for (int k = 0; k < 8; ++k) {
        const glm::dvec3 c((k & 1) != 0 ? hi.x : lo.x, (k & 2) != 0 ? hi.y : lo.y, (k & 4) != 0 ? hi.z : lo.z);
        far = std::max(far, glm::length(c - view.eye));
      }
      return std::min(largestHalf,
                      std::max(leastHalf, pixelsHalf * pixelScaleOf(view.viewProj, height).metresPerPixel * far));
    }
  };

  [[nodiscard]] LayerReach reachOf(const OverlayLayer& layer) const {
    LayerReach r;
    for (const FeatureStyle& f : layer.featureStyles()) {
      if (layer.kind() != LayerKind::Line || !f.shape.inPixels()) continue;
      r.pixels = true;
      r.pixelsHalf = std::max(r.pixelsHalf, 0.5 * f.shape.widthPixels);
      r.leastHalf = std::max(r.leastHalf, 0.5 * f.shape.minWidth);
      r.largestHalf = std::max(r.largestHalf, 0.5 * f.shape.width);
    }
    const SharedFeatures& features = layer.sharedFeatures();
    glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (std::size_t i = 0; i < features.size(); ++i) {
      const auto [a, b] = features.box(i, layer.kind() == LayerKind::Line);
      if (!(a.x <= b.x && a.y <= b.y)) continue;
      lo = glm::min(lo, a);
      hi = glm::max(hi, b);
    }
    const HeightBounds h = bounds_ != nullptr ? bounds_->globalBounds() : HeightBounds{-1e4, 1e4};
    const double grow = std::min(r.largestHalf, reachOfClass(kLargestReachClass));  // as the lines are binned
    r.lo = glm::dvec3(lo - glm::dvec2(grow), h.lo);
    r.hi = glm::dvec3(hi + glm::dvec2(grow), h.hi);
    // About 160 bytes a source vertex (entries, leaves and grid) on the samples measured.
    r.estimatedBytes = features.vertexCount() * 160;
    return r;
  }

  const LayerReach& reachInfo(const OverlayLayer& layer) {
    auto found = reach_.find(&layer);
    if (found == reach_.end()) found = reach_.emplace(&layer, reachOf(layer)).first;
    return found->second;
  }

  /// The reach a class bins lines in pixels at.
  [[nodiscard]] double reachOfClass(int c) const {
    if (c == kNaturalReach || !std::isfinite(maxReach_)) return maxReach_;
    return std::ldexp(maxReach_, c);
  }

  /// The class whose index draws the layer exactly in this view: kNaturalReach when its lines
  /// keep within the base reach (or it has no lines in pixels, or there is no base reach), the
  /// smallest class holding the widest half width in view, or kNoReach beyond every class.
  int reachClass(const OverlayLayer& layer, const OverlayView& view, int height) {
    if (!std::isfinite(maxReach_)) return kNaturalReach;
    const LayerReach& r = reachInfo(layer);
    if (!r.pixels || r.largestHalf <= maxReach_) return kNaturalReach;
    const double widest = r.widestHalf(view, height);
    for (int c = 0; c <= kLargestReachClass; ++c)
      if (widest <= reachOfClass(c)) return c;
    return kNoReach;
  }

  void dropAll() {
    lastLayers_.clear();
    reach_.clear();
    layers_.clear();
    arena_ = Arena{};
    arenaSlot_.clear();
  }

  static void upload(gfx::BufferHandle& buffer, std::size_t& capacity, const void* data, std::size_t bytes) {
    if (capacity < bytes) {
      capacity = std::max(bytes, 2 * capacity);
      buffer = gfx::createBuffer();
      glNamedBufferData(buffer.id(), static_cast<GLsizeiptr>(capacity), nullptr, GL_STREAM_DRAW);
    }
    glNamedBufferSubData(buffer.id(), 0, static_cast<GLsizeiptr>(bytes), data);
  }

  /// Builds the indices not made yet and lays out the arena for these layers (null keys skipped).
  void ensureArena(const std::vector<IndexKey>& keys) {
    std::vector<IndexKey> wanted;
    for (const IndexKey& key : keys) {
      if (key.first == nullptr) continue;
      if (!layers_.contains(key)) layers_.emplace(key, indexOf(*key.first, reachOfClass(key.second)));
      wanted.push_back(key);
    }
    if (wanted == arena_.layers) return;
    arena_ = Arena{};
    arenaSlot_.clear();
    std::vector<std::uint8_t> nodes, groups, edges, items, features, grid;
    for (const IndexKey& key : wanted) {
      const deferred::Index& index = layers_.at(key).index;
      LayerHeader h;
      h.nodeBase = static_cast<std::uint32_t>(nodes.size() / sizeof(deferred::Node));
      h.entryBase =
          static_cast<std::uint32_t>(index.kind == LayerKind::Polygon ? groups.size() / sizeof(deferred::Group)
                                                                      : items.size() / sizeof(deferred::Item));
      h.edgeBase = static_cast<std::uint32_t>(edges.size() / sizeof(deferred::Edge));
      h.featureBase = static_cast<std::uint32_t>(features.size() / sizeof(deferred::FeatureParams));
      h.polygons = index.kind == LayerKind::Polygon ? 1U : 0U;
      h.depth = static_cast<std::uint32_t>(index.depth);
      h.cellSize = static_cast<float>(index.cellSize());
      h.gridBase = static_cast<std::uint32_t>(grid.size() / sizeof(std::uint32_t));
      h.gridLevel = static_cast<std::uint32_t>(index.gridLevel);
      h.inPixels = index.inPixels ? 1U : 0U;
      append(grid, index.grid);
      append(nodes, index.nodes);
      append(groups, index.groups);
      append(edges, index.edges);
      append(items, index.items);
      append(features, index.features);
      arenaSlot_[key] = arena_.headers.size();
      arena_.headers.push_back(h);
    }
    arena_.bytes = nodes.size() + groups.size() + edges.size() + items.size() + features.size() + grid.size();
    arena_.grid = bufferOf(std::move(grid));
    arena_.nodes = bufferOf(std::move(nodes));
    arena_.groups = bufferOf(std::move(groups));
    arena_.edges = bufferOf(std::move(edges));
    arena_.items = bufferOf(std::move(items));
    arena_.features = bufferOf(std::move(features));
    arena_.layers = std::move(wanted);
  }

  [[nodiscard]] LayerIndex indexOf(const OverlayLayer& layer, double maxReach) const {
    LayerIndex li;
    std::vector<glm::vec4> colors;
    colors.reserve(layer.featureStyles().size());
    for (const FeatureStyle& s : layer.featureStyles()) colors.push_back(s.color);
    deferred::BuildOptions options;
    options.maxReach = maxReach;
    options.region = region_;
    li.index = deferred::build(referenceLayerOf(layer), colors, options);
    for (const auto& box : li.index.cover) {
      HeightBounds h{-1e5, 1e5};
      if (bounds_ != nullptr) {
        const std::array<glm::dvec2, 4> corners{box[0], glm::dvec2(box[1].x, box[0].y), box[1],
                                                glm::dvec2(box[0].x, box[1].y)};
        h = bounds_->boundsOver(corners);
        if (!h.valid()) h = {-1e5, 1e5};
      }
      li.cover.push_back({glm::dvec3(box[0], h.lo), glm::dvec3(box[1], h.hi)});
    }
    return li;
  }

  double maxReach_;
  /// The terrain's extent (the build's cell grid): ground points lie there, so the indices cover
  /// no more (deferred::BuildOptions::region).
  std::optional<std::array<glm::dvec2, 2>> region_;
  gfx::Program single_, multi_;
  const HeightBoundsProvider* bounds_;
  gfx::VertexArrayHandle vao_;
  gfx::BufferHandle rects_, headers_;
  std::size_t rectsCapacity_ = 0, headersCapacity_ = 0;
  DepthSource depth_;
  std::unordered_map<IndexKey, LayerIndex, IndexKeyHash> layers_;
  std::unordered_map<IndexKey, std::size_t, IndexKeyHash> arenaSlot_;
  std::unordered_map<const OverlayLayer*, LayerReach> reach_;
  std::vector<const OverlayLayer*> lastLayers_;  ///< the last frame's layers (featureChanged's indices)
  Arena arena_;
  gfx::GpuTimer timer_;
  gfx::PipelineStatistics statistics_;
};

Result<std::unique_ptr<DeferredTechnique>> make(const TechniqueOptions& options, double maxReach) {
  Result<std::unique_ptr<DeferredTechnique>> result;
  Result<gfx::Program> single = gfx::Program::build({{"overlay_cover_rects.vert", {}}, {"overlay_deferred.frag", {}}});
  Result<gfx::Program> multi =
      gfx::Program::build({{"overlay_cover_rects.vert", {}}, {"overlay_deferred.frag", {"MULTISAMPLE"}}});
  result.diagnostics.append(single.diagnostics);
  result.diagnostics.append(multi.diagnostics);
  if (!single || !multi) return result;
  // Ground points lie on the terrain, within the cell grid the stencil technique clips its pieces
  // to: an index covers no more, so that one feature reaching far beyond (a line 1e15 m wide)
  // costs what one covering the terrain does.
  std::optional<std::array<glm::dvec2, 2>> region;
  if (const std::optional<CellGrid>& cells = options.build.footprints.cells) {
    region = std::array<glm::dvec2, 2>{cells->origin,
                                       cells->origin + cells->cellSize * glm::dvec2(cells->columns, cells->rows)};
  }
  result.value =
      std::make_unique<DeferredTechnique>(std::move(*single), std::move(*multi), options.bounds, maxReach, region);
  return result;
}

Result<std::unique_ptr<OverlayTechnique>> create(const TechniqueOptions& options) {
  Result<std::unique_ptr<DeferredTechnique>> made = make(options, std::numeric_limits<double>::infinity());
  Result<std::unique_ptr<OverlayTechnique>> result;
  result.diagnostics = std::move(made.diagnostics);
  if (made) result.value = std::move(*made);
  return result;
}

}  // namespace

Result<std::unique_ptr<DeferredLookup>> createDeferredLookup(const TechniqueOptions& options, double maxReach) {
  Result<std::unique_ptr<DeferredTechnique>> made = make(options, maxReach);
  Result<std::unique_ptr<DeferredLookup>> result;
  result.diagnostics = std::move(made.diagnostics);
  if (made) result.value = std::move(*made);
  return result;
}

const TechniqueInfo kDeferredTechnique{
    "deferred",
    "deferred per-pixel lookup",
    "per pixel, the ground point from the depth buffer tested against a quadtree of the layer's edges and lines",
    "#8c564b",
    PieceConstruction::Features,
    0,
    {},
    &create};

}  // namespace gis::overlay
