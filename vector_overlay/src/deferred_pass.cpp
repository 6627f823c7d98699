// The deferred lookup's pass (deferred_lookup.hpp): the layers' indices, every chart of every
// layer, one after another in shared storage buffers (the arena), and one draw over the screen
// rectangles their cover boxes project to. The shader (overlay_deferred.frag) reads the depth
// from the target's own depth texture, or a copy of the target's depth buffer (a blit per frame),
// so any framebuffer, the default one included, can be drawn into.
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <unordered_map>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "deferred_pass.hpp"
#include "gfx/handles.hpp"
#include "gfx/program.hpp"
#include "gfx/queries.hpp"
#include "screen_tiles.hpp"
#include "vector_overlay/footprints.hpp"

namespace gis::overlay {

namespace {

constexpr GLuint kRectsBinding = 3;  // overlay_cover_rects.vert
/// overlay_deferred.frag's uniform block of kMaxHeaders headers: at most 16 KB, the least GL
/// allows.
constexpr GLuint kLayersBinding = 1;
constexpr std::size_t kMaxHeaders = 112;
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

/// Per chart of a drawn layer, what the shader reads of it (std140, overlay_deferred.frag's Layer).
struct LayerHeader {
  std::uint32_t nodeBase = 0, entryBase = 0, edgeBase = 0, featureBase = 0;
  std::uint32_t polygons = 0, depth = 0;
  float maskBit = 0.0F, cellSize = 0.0F;
  std::int32_t eyeCellX = 0, eyeCellY = 0;
  float eyeRemainderX = 0.0F, eyeRemainderY = 0.0F;
  std::uint32_t gridBase = 0, gridLevel = 0, inPixels = 0;
  std::uint32_t face = 0;  ///< 0: the frame's plane; f + 1: cube face f
  // A face (DeferredChart): its directions, the eye relative to the anchor, and the anchor's
  // coordinates along them with the chart's scale.
  std::array<float, 4> axis{}, east{}, north{}, fromAnchor{}, anchorDots{};
};
static_assert(sizeof(LayerHeader) == 144);
static_assert(kMaxHeaders * sizeof(LayerHeader) <= 16384);

/// One array of the arena: the charts' arrays of one kind end to end in one buffer, copied from
/// the indices straight into it (no array of the whole arena on the CPU). A change of the drawn
/// layers (a view needing another reach class) lays the arena out again: the buffer is kept when
/// it holds the new part and is not more than twice its size, so such a change allocates (and the
/// driver clears) no new storage.
class ArenaPart {
 public:
  /// Places `data` after what is placed; returns where it starts, in elements of T (each part
  /// holds one type).
  template <typename T>
  std::uint32_t place(const std::vector<T>& data) {
    const auto base = static_cast<std::uint32_t>(bytes_ / sizeof(T));
    pieces_.emplace_back(data.data(), data.size() * sizeof(T));
    bytes_ += data.size() * sizeof(T);
    return base;
  }
  [[nodiscard]] std::size_t bytes() const { return bytes_; }
  /// Into `buffer` of `capacity` bytes (made again, and `capacity` set, when it must be).
  void upload(gfx::BufferHandle& buffer, std::size_t& capacity) const {
    const std::size_t wanted = std::max<std::size_t>(bytes_, 16);  // binding a zero-sized range is an error
    if (capacity < wanted || capacity > 2 * wanted) {
      buffer = gfx::createBuffer();
      glNamedBufferData(buffer.id(), static_cast<GLsizeiptr>(wanted), nullptr, GL_STATIC_DRAW);
      capacity = wanted;
    }
    GLintptr at = 0;
    for (const auto& [data, size] : pieces_) {
      if (size > 0) glNamedBufferSubData(buffer.id(), at, static_cast<GLsizeiptr>(size), data);
      at += static_cast<GLintptr>(size);
    }
  }

 private:
  std::vector<std::pair<const void*, std::size_t>> pieces_;
  std::size_t bytes_ = 0;
};

void upload(gfx::BufferHandle& buffer, std::size_t& capacity, const void* data, std::size_t bytes) {
  if (capacity < bytes) {
    capacity = std::max(bytes, 2 * capacity);
    buffer = gfx::createBuffer();
    glNamedBufferData(buffer.id(), static_cast<GLsizeiptr>(capacity), nullptr, GL_STREAM_DRAW);
  }
  glNamedBufferSubData(buffer.id(), 0, static_cast<GLsizeiptr>(bytes), data);
}

std::array<float, 4> vec4Of(const glm::dvec3& v, double w = 0.0) {
  return {static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z), static_cast<float>(w)};
}

/// The anchor of a face for an eye: the point of the face's region (grown by its margin) nearest
/// below the eye, on the ellipsoid. The ground points of the face seen from the eye are no
/// nearer to the eye than it is far from them, so offsets from it stay as small as the view's.
glm::dvec3 anchorOf(const DeferredChart& chart, const glm::dvec3& eye) {
  const glm::dvec3 d = glm::normalize(eye);
  const double along = std::max(glm::dot(chart.axis, d), 0.2);
  const double limit = 1.0 + DeferredChart::kFaceMargin;
  const glm::dvec2 g = glm::clamp(glm::dvec2(glm::dot(chart.east, d), glm::dot(chart.north, d)) / along,
                                  glm::dvec2(-limit), glm::dvec2(limit));
  return chart.unproject(g * chart.scale);
}

}  // namespace

struct DeferredPass::State {
  gfx::Program single, multi;
  gfx::VertexArrayHandle vao = gfx::createVertexArray();
  gfx::BufferHandle rects = gfx::createBuffer(), headers = gfx::createBuffer();
  std::size_t rectsCapacity = 0, headersCapacity = 0;
  DepthSource depth;
  // The arena: the charts of these layers (by serial), laid out in this order.
  std::vector<std::uint64_t> layers;
  std::unordered_map<std::uint64_t, std::size_t> firstHeader;  ///< per layer: its first chart's header
  std::vector<LayerHeader> headerTemplate;                     ///< per chart: its offsets
  gfx::BufferHandle nodes, groups, edges, items, features, grid;
  std::array<std::size_t, 6> capacities{};  ///< of nodes, groups, edges, items, features and grid
  std::size_t bytes = 0;                    ///< their sum
  gfx::GpuTimer timer;
  gfx::PipelineStatistics statistics;

  /// Lays out the arena for these layers unless it holds them already.
  void arrange(std::span<const DeferredLayer* const> drawn) {
    std::vector<std::uint64_t> wanted;
    for (const DeferredLayer* layer : drawn) {
      if (layer != nullptr) wanted.push_back(layer->serial());
    }
    if (wanted == layers) return;
    firstHeader.clear();
    headerTemplate.clear();
    ArenaPart n, g, e, it, f, gr;
    for (const DeferredLayer* layer : drawn) {
      if (layer == nullptr || firstHeader.contains(layer->serial())) continue;
      firstHeader[layer->serial()] = headerTemplate.size();
      for (const DeferredLayer::Impl::Chart& chart : layer->impl().charts) {
        const deferred::Index& index = chart.index;
        LayerHeader h;
        h.nodeBase = n.place(index.nodes);
        const std::uint32_t groupBase = g.place(index.groups), itemBase = it.place(index.items);
        h.entryBase = index.kind == LayerKind::Polygon ? groupBase : itemBase;
        h.edgeBase = e.place(index.edges);
        h.featureBase = f.place(index.features);
        h.gridBase = gr.place(index.grid);
        h.polygons = index.kind == LayerKind::Polygon ? 1U : (index.world ? 2U : 0U);
        h.depth = static_cast<std::uint32_t>(index.depth);
        h.cellSize = static_cast<float>(index.cellSize());
        h.gridLevel = static_cast<std::uint32_t>(index.gridLevel);
        h.inPixels = index.inPixels ? 1U : 0U;
        h.face = chart.chart.face < 0 ? 0U : static_cast<std::uint32_t>(chart.chart.face + 1);
        headerTemplate.push_back(h);
      }
    }
    n.upload(nodes, capacities[0]);
    g.upload(groups, capacities[1]);
    e.upload(edges, capacities[2]);
    it.upload(items, capacities[3]);
    f.upload(features, capacities[4]);
    gr.upload(grid, capacities[5]);
    bytes = 0;
    for (const std::size_t c : capacities) bytes += c;
    layers = std::move(wanted);
  }
};

DeferredPass::DeferredPass(std::unique_ptr<State> state) : state_(std::move(state)) {}
DeferredPass::DeferredPass(DeferredPass&&) noexcept = default;
DeferredPass& DeferredPass::operator=(DeferredPass&&) noexcept = default;
DeferredPass::~DeferredPass() = default;

Result<DeferredPass> DeferredPass::create() {
  Result<DeferredPass> result;
  Result<gfx::Program> single = gfx::Program::build({{"overlay_cover_rects.vert", {}}, {"overlay_deferred.frag", {}}});
  Result<gfx::Program> multi =
      gfx::Program::build({{"overlay_cover_rects.vert", {}}, {"overlay_deferred.frag", {"MULTISAMPLE"}}});
  result.diagnostics.append(single.diagnostics);
  result.diagnostics.append(multi.diagnostics);
  if (!single || !multi) return result;
  auto state = std::make_unique<State>();
  state->single = std::move(*single);
  state->multi = std::move(*multi);
  result.value = DeferredPass(std::move(state));
  return result;
}

std::size_t DeferredPass::gpuBytes() const { return state_->depth.bytes() + state_->bytes; }

void DeferredPass::draw(gfx::StateCache& cache, const DrawTarget& target, const OverlayView& view,
                        std::span<const DeferredLayer* const> layers, bool measure,
                        std::vector<LayerFrameStats>& stats) {
  State& s = *state_;
  stats.resize(std::max(stats.size(), layers.size()));
  s.arrange(layers);
  ScreenTiles tiles(kScreenTiles);
  std::vector<LayerHeader> headers;
  std::optional<std::size_t> first;
  for (std::size_t i = 0; i < layers.size(); ++i) {
    const DeferredLayer* layer = layers[i];
    if (layer == nullptr) continue;
    std::size_t slot = s.firstHeader.at(layer->serial());
    bool drawn = false;
    for (const DeferredLayer::Impl::Chart& chart : layer->impl().charts) {
      LayerHeader h = s.headerTemplate[slot++];
      if (chart.index.empty()) continue;
      bool onScreen = false;
      for (const auto& box : chart.cover) {
        const glm::vec4 r = screenRect(view.viewProj, view.nearPlane, box[0], box[1]);
        onScreen = onScreen || (r.z >= r.x && r.w >= r.y);
        tiles.add(r);
      }
      if (!onScreen) continue;
      glm::dvec3 anchor = view.eye;  // the frame's plane: the eye
      if (chart.chart.face >= 0) {
        const glm::dvec3 q = anchorOf(chart.chart, view.eye);
        anchor = glm::dvec3(chart.chart.project(q), 0.0);
        // The index's corner in the chart (axis.w, east.w): where a leaf's corner lies, for lines
        // in space (their items are relative to it).
        h.axis = vec4Of(chart.chart.axis, chart.index.origin.x);
        h.east = vec4Of(chart.chart.east, chart.index.origin.y);
        h.north = vec4Of(chart.chart.north);
        h.fromAnchor = vec4Of(view.eye - q);
        h.anchorDots =
            vec4Of({glm::dot(chart.chart.axis, q), glm::dot(chart.chart.east, q), glm::dot(chart.chart.north, q)},
                   chart.chart.scale);
      }
      const deferred::EyeCells eye = deferred::eyeCells(chart.index, anchor);
      h.eyeCellX = eye.cell.x;
      h.eyeCellY = eye.cell.y;
      h.eyeRemainderX = eye.remainder.x;
      h.eyeRemainderY = eye.remainder.y;
      h.maskBit = static_cast<float>(std::uint32_t{1} << std::min<std::size_t>(i, 23));
      headers.push_back(h);
      drawn = true;
    }
    if (!drawn) continue;
    stats[i].rectangleCover = true;
    if (!first) first = i;
  }
  const std::vector<glm::vec4> rects = tiles.rects();
  if (headers.empty() || rects.empty()) return;
  LayerFrameStats& counted = stats[*first];
  counted.drawCommands = 1;

  const GLuint depth = s.depth.texture(target);
  gfx::Program& program = s.depth.multisampled() ? s.multi : s.single;
  cache.useProgram(program);
  cache.bindTexture(kDepthUnit, depth);
  cache.bindVertexArray(s.vao.id());
  gfx::PipelineState state;
  state.depth.test = false;
  state.depth.write = false;
  state.blend = gfx::kBlendPremultipliedOver;
  state.raster.cull = gfx::CullMode::None;
  cache.apply(state);
  const glm::dmat4 relative = view.viewProj * glm::translate(glm::dmat4(1.0), view.eye);
  program.set("u_depth", static_cast<int>(kDepthUnit));
  program.set("u_inverse", glm::mat4(glm::inverse(relative)));
  program.set("u_viewport", glm::vec2(target.width, target.height));
  program.set("u_eyeZ", static_cast<float>(view.eye.z));
  program.set("u_eyeWorld", glm::vec3(view.eye));
  // The ellipsoid of the faces (every face of a frame has the same; unused in the plane).
  glm::dvec3 radii(1.0);
  for (const DeferredLayer* layer : layers) {
    if (layer == nullptr) continue;
    for (const DeferredLayer::Impl::Chart& chart : layer->impl().charts) {
      if (chart.chart.face >= 0) radii = chart.chart.radii;
    }
  }
  program.set("u_radii", glm::vec3(radii));
  program.set("u_metresPerPixel", static_cast<float>(pixelScaleOf(view.viewProj, target.height).metresPerPixel));
  upload(s.rects, s.rectsCapacity, rects.data(), rects.size() * sizeof(glm::vec4));
  cache.bindStorageBuffer(kRectsBinding, s.rects.id());
  cache.bindStorageBuffer(kNodesBinding, s.nodes.id());
  cache.bindStorageBuffer(kGroupsBinding, s.groups.id());
  cache.bindStorageBuffer(kEdgesBinding, s.edges.id());
  cache.bindStorageBuffer(kItemsBinding, s.items.id());
  cache.bindStorageBuffer(kFeaturesBinding, s.features.id());
  cache.bindStorageBuffer(kGridBinding, s.grid.id());
  if (measure) {
    s.timer.begin();
    s.statistics.begin();
  }
  // The uniform block holds kMaxHeaders charts: more are drawn in further passes, each blended
  // over the last (the same as one pass: a pixel lies in one chart of a layer).
  for (std::size_t batch = 0; batch < headers.size(); batch += kMaxHeaders) {
    const std::size_t count = std::min(kMaxHeaders, headers.size() - batch);
    std::vector<LayerHeader> block(kMaxHeaders);
    std::copy_n(headers.begin() + static_cast<std::ptrdiff_t>(batch), count, block.begin());
    upload(s.headers, s.headersCapacity, block.data(), block.size() * sizeof(LayerHeader));
    cache.bindUniformBuffer(kLayersBinding, s.headers.id());
    program.set("u_layerCount", static_cast<int>(count));
    glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, static_cast<GLsizei>(rects.size()));
  }
  if (measure) {
    s.statistics.end();
    s.timer.end();
    counted.coverMilliseconds = static_cast<double>(s.timer.nanoseconds().value_or(0)) * 1e-6;
    counted.gpuMilliseconds = counted.coverMilliseconds;
    const gfx::PipelineCounts counts = s.statistics.result();
    counted.coverFragments = counts.fragmentShaderInvocations;
    counted.coverTriangles = counts.primitivesSubmitted;
  }
}

}  // namespace gis::overlay
