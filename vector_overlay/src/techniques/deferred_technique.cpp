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
#include <chrono>
#include <cstring>
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
constexpr GLuint kNodesBinding = 4;  // overlay_deferred.frag
constexpr GLuint kGroupsBinding = 5;
constexpr GLuint kEdgesBinding = 6;
constexpr GLuint kItemsBinding = 7;
constexpr GLuint kFeaturesBinding = 8;
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

/// A copy of the target's depth, remade when its size or format changes.
class DepthCopy {
 public:
  /// Copies the depth of `framebuffer` (width × height); returns the texture.
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
  [[nodiscard]] bool multisampled() const { return format_.samples > 0; }
  [[nodiscard]] std::size_t bytes() const {
    return static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_) *
           static_cast<std::size_t>(std::max(1, format_.samples)) * 8;
  }

 private:
  DepthFormat format_;
  int width_ = 0, height_ = 0;
  gfx::TextureHandle texture_;
  gfx::FramebufferHandle framebuffer_;
};

/// A layer's index on the GPU.
struct LayerIndex {
  deferred::Index index;
  std::vector<std::array<glm::dvec3, 2>> cover;  ///< the index's cover boxes with the terrain's heights
  gfx::BufferHandle nodes, groups, edges, items, features;
  double buildSeconds = 0.0;
  std::size_t gpuBytes = 0;
};

template <typename T>
gfx::BufferHandle upload(const std::vector<T>& data) {
  // An empty array still gets a buffer (binding a zero-sized range is an error).
  const std::size_t bytes = std::max<std::size_t>(data.size() * sizeof(T), 16);
  std::vector<std::uint8_t> padded(bytes, 0);
  if (!data.empty()) std::memcpy(padded.data(), data.data(), data.size() * sizeof(T));
  return gfx::createBufferWithData(padded.data(), bytes);
}

class DeferredTechnique final : public OverlayTechnique {
 public:
  DeferredTechnique(gfx::Program single, gfx::Program multi, const HeightBoundsProvider* bounds)
      : single_(std::move(single)),
        multi_(std::move(multi)),
        bounds_(bounds),
        vao_(gfx::createVertexArray()),
        rects_(gfx::createBuffer()) {}

  std::optional<SurfaceDrape> prepareFrame(gfx::StateCache& cache, const TechniqueFrame& frame,
                                           TechniqueFrameStats& stats) override {
    (void)cache;
    (void)frame;
    (void)stats;
    return std::nullopt;
  }

  void drawFrame(gfx::StateCache& cache, const TechniqueFrame& frame, TechniqueFrameStats& stats) override {
    stats.layers.assign(frame.layers.size(), LayerFrameStats{});
    if (std::none_of(frame.layers.begin(), frame.layers.end(), [](const OverlayLayer* l) { return l != nullptr; }))
      return;
    const GLuint depth = depthCopy_.copy(frame.target);
    gfx::Program& program = depthCopy_.multisampled() ? multi_ : single_;
    cache.useProgram(program);
    cache.bindTexture(kDepthUnit, depth);
    cache.bindVertexArray(vao_.id());
    gfx::PipelineState state;
    state.depth.test = false;
    state.depth.write = false;
    state.blend = gfx::kBlendPremultipliedOver;
    state.raster.cull = gfx::CullMode::None;
    cache.apply(state);
    const OverlayView& view = frame.view;
    const glm::dmat4 relative = view.viewProj * glm::translate(glm::dmat4(1.0), view.eye);
    program.set("u_depth", static_cast<int>(kDepthUnit));
    program.set("u_inverse", glm::mat4(glm::inverse(relative)));
    program.set("u_viewport", glm::vec2(frame.target.width, frame.target.height));
    program.set("u_eyeZ", static_cast<float>(view.eye.z));
    const PixelScale scale = pixelScaleOf(view.viewProj, frame.target.height);
    program.set("u_metresPerPixel", static_cast<float>(scale.metresPerPixel));

    for (std::size_t i = 0; i < frame.layers.size() && i < 32; ++i) {
      const OverlayLayer* layer = frame.layers[i];
      if (layer == nullptr) continue;
      LayerIndex& li = indexOf(*layer);
      if (li.index.empty()) continue;
      ScreenTiles tiles(kScreenTiles);
      for (const auto& box : li.cover) tiles.add(screenRect(view.viewProj, view.nearPlane, box[0], box[1]));
      const std::vector<glm::vec4> rects = tiles.rects();
      LayerFrameStats& s = stats.layers[i];
      s.rectangleCover = true;
      s.drawCommands = rects.empty() ? 0 : 1;
      if (rects.empty()) continue;
      const deferred::EyeCells eye = deferred::eyeCells(li.index, view.eye);
      glProgramUniform2i(program.id(), program.location("u_eyeCell"), eye.cell.x, eye.cell.y);
      program.set("u_eyeRemainder", eye.remainder);
      program.set("u_cellSize", static_cast<float>(li.index.cellSize()));
      program.set("u_depthLevels", li.index.depth);
      program.set("u_polygons", li.index.kind == LayerKind::Polygon ? 1 : 0);
      program.set("u_maskBit", static_cast<float>(1U << i));
      cache.bindStorageBuffer(kNodesBinding, li.nodes.id());
      cache.bindStorageBuffer(kGroupsBinding, li.groups.id());
      cache.bindStorageBuffer(kEdgesBinding, li.edges.id());
      cache.bindStorageBuffer(kItemsBinding, li.items.id());
      cache.bindStorageBuffer(kFeaturesBinding, li.features.id());
      const std::size_t bytes = rects.size() * sizeof(glm::vec4);
      if (rectsCapacity_ < bytes) {
        rectsCapacity_ = std::max(bytes, 2 * rectsCapacity_);
        rects_ = gfx::createBuffer();
        glNamedBufferData(rects_.id(), static_cast<GLsizeiptr>(rectsCapacity_), nullptr, GL_STREAM_DRAW);
      }
      glNamedBufferSubData(rects_.id(), 0, static_cast<GLsizeiptr>(bytes), rects.data());
      cache.bindStorageBuffer(kRectsBinding, rects_.id());
      if (frame.settings.measure) {
        timer_.begin();
        statistics_.begin();
      }
      glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, static_cast<GLsizei>(rects.size()));
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
  }

  void invalidate() override { layers_.clear(); }
  void invalidate(const glm::dvec2& lo, const glm::dvec2& hi) override {
    (void)lo;
    (void)hi;
    layers_.clear();
  }
  void featureChanged(std::size_t layer, std::size_t feature, const glm::dvec2& lo, const glm::dvec2& hi) override {
    // The layer's index is made again at the next frame (one layer: its features only).
    (void)layer;
    (void)feature;
    (void)lo;
    (void)hi;
    layers_.clear();
  }
  [[nodiscard]] std::size_t gpuBytes() const override {
    std::size_t bytes = depthCopy_.bytes();
    for (const auto& [layer, li] : layers_) bytes += li.gpuBytes;
    return bytes;
  }

 private:
  LayerIndex& indexOf(const OverlayLayer& layer) {
    const auto found = layers_.find(&layer);
    if (found != layers_.end()) return found->second;
    const auto start = std::chrono::steady_clock::now();
    LayerIndex li;
    std::vector<glm::vec4> colors;
    colors.reserve(layer.featureStyles().size());
    for (const FeatureStyle& s : layer.featureStyles()) colors.push_back(s.color);
    li.index = deferred::build(referenceLayerOf(layer), colors);
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
    li.nodes = upload(li.index.nodes);
    li.groups = upload(li.index.groups);
    li.edges = upload(li.index.edges);
    li.items = upload(li.index.items);
    li.features = upload(li.index.features);
    li.gpuBytes = li.index.bytes();
    li.buildSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return layers_.emplace(&layer, std::move(li)).first->second;
  }

  gfx::Program single_, multi_;
  const HeightBoundsProvider* bounds_;
  gfx::VertexArrayHandle vao_;
  gfx::BufferHandle rects_;
  std::size_t rectsCapacity_ = 0;
  DepthCopy depthCopy_;
  std::unordered_map<const OverlayLayer*, LayerIndex> layers_;
  gfx::GpuTimer timer_;
  gfx::PipelineStatistics statistics_;
};

Result<std::unique_ptr<OverlayTechnique>> create(const TechniqueOptions& options) {
  Result<std::unique_ptr<OverlayTechnique>> result;
  Result<gfx::Program> single = gfx::Program::build({{"overlay_cover_rects.vert", {}}, {"overlay_deferred.frag", {}}});
  Result<gfx::Program> multi =
      gfx::Program::build({{"overlay_cover_rects.vert", {}}, {"overlay_deferred.frag", {"MULTISAMPLE"}}});
  result.diagnostics.append(single.diagnostics);
  result.diagnostics.append(multi.diagnostics);
  if (!single || !multi) return result;
  result.value = std::make_unique<DeferredTechnique>(std::move(*single), std::move(*multi), options.bounds);
  return result;
}

}  // namespace

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
