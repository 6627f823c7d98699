#pragma once
// Texture draping: the baseline that osgEarth, MapLibre, deck.gl and iTowns use instead of
// stencil polyhedra. The layers are rasterised once, flat, into a texture over the terrain's
// extent, and the terrain shader samples it (TerrainEngine::setDrape). Its error comes from the
// texel size; its cost is the texture's memory and the time to rasterise it again after an
// edit. Kept here as the benchmark's comparison (issue 7) and as a method of the viewer.
//
// What a texel holds follows the stencil cover: each layer is blended once per texel, in the
// order given, and where a layer's features overlap the first drawn wins. The texel's centre
// decides (GL's rasterisation rules), so a feature narrower than a texel may vanish.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <list>
#include <span>
#include <unordered_map>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec4.hpp>

#include "core/diagnostics.hpp"
#include "gfx/handles.hpp"
#include "gfx/program.hpp"
#include "gfx/state_cache.hpp"
#include "vector_overlay/overlay_layer.hpp"

namespace gis::overlay {

/// The ground the texture covers, in frame coordinates.
struct DrapeExtent {
  glm::dvec2 origin{0.0};  ///< minimum corner
  glm::dvec2 size{1.0};    ///< metres, both > 0
};

/// What a drape rasterises: its layers' triangles in the plane of the texture, each with its
/// colour (straight alpha). The plane is a frame's: a projected frame's x and y in metres, or the
/// globe's longitude and latitude in degrees (globe::GlobeDrapeSource), whose terrain tiles are
/// linear in both; so one rasteriser, one texture cache and one terrain lookup serve both frames.
class DrapeSource {
 public:
  using TriangleSink =
      std::function<void(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c, const glm::vec4& colour)>;
  virtual ~DrapeSource() = default;
  DrapeSource() = default;
  DrapeSource(const DrapeSource&) = delete;
  DrapeSource& operator=(const DrapeSource&) = delete;

  /// Layers in draw order: layer i writes mask bit i.
  [[nodiscard]] virtual std::size_t layerCount() const = 0;
  /// Layer i's visible triangles that may meet the box [lo, hi], into `emit` (others may come
  /// too: the rasteriser clips). `texel` is the texture's texel there (plane units), what the
  /// source may generalise by, and draw lines in pixels at.
  virtual void triangles(std::size_t layer, const glm::dvec2& lo, const glm::dvec2& hi, const glm::dvec2& texel,
                         const TriangleSink& emit) const = 0;
};

/// The projected frame's: the visible footprints of the layers' pieces (null entries are skipped,
/// their bits stay), lines in pixels at their largest width (a texture cannot follow the view).
class FootprintDrapeSource final : public DrapeSource {
 public:
  explicit FootprintDrapeSource(std::span<const OverlayLayer* const> layers) : layers_(layers) {}
  [[nodiscard]] std::size_t layerCount() const override { return layers_.size(); }
  void triangles(std::size_t layer, const glm::dvec2& lo, const glm::dvec2& hi, const glm::dvec2& texel,
                 const TriangleSink& emit) const override;

 private:
  std::span<const OverlayLayer* const> layers_;
};

struct DrapeStats {
  int size = 0;               ///< texels per side
  std::size_t triangles = 0;  ///< rasterised
  std::size_t gpuBytes = 0;   ///< colour with its mip levels, and the mask
  double buildSeconds = 0.0;  ///< rasterising and mip-mapping, waited for (glFinish)
};

class TextureDrape {
 public:
  /// Rasterises the triangles of `source` (bit i of the mask is its layer i) into a `size` ×
  /// `size` colour texture (premultiplied RGBA8, mip-mapped, linear filtering) and a mask texture
  /// (R32F, layer bits, nearest) over `extent`. Needs a current GL context; `cache` is left
  /// consistent. Fails for a size outside [1, the GL maximum] or an empty extent.
  static Result<TextureDrape> build(gfx::StateCache& cache, const DrapeSource& source, const DrapeExtent& extent,
                                    int size);

  [[nodiscard]] GLuint colorTexture() const { return color_.id(); }
  [[nodiscard]] GLuint maskTexture() const { return mask_.id(); }
  [[nodiscard]] const DrapeExtent& extent() const { return extent_; }
  [[nodiscard]] int size() const { return stats_.size; }
  [[nodiscard]] const DrapeStats& stats() const { return stats_; }

  /// The mask texels, row 0 at the extent's minimum y (texture order).
  [[nodiscard]] std::vector<std::uint32_t> readMask() const;
  /// The layer bits of the texel under a frame point (nearest), as the terrain shader reads them:
  /// 0 outside the extent. `mask` is readMask().
  [[nodiscard]] std::uint32_t maskAt(const std::vector<std::uint32_t>& mask, const glm::dvec2& point) const;

 private:
  TextureDrape() = default;
  gfx::TextureHandle color_;
  gfx::TextureHandle mask_;
  DrapeExtent extent_;
  DrapeStats stats_;
};

/// Draping per quadtree tile, as osgEarth and iTowns do: each drawn terrain chunk gets its own
/// `tileSize`² texture over its extent (a layer of a texture array), rasterised when the chunk
/// is first drawn and kept while it is in use (least recently used tiles are reused). Finer
/// chunks near the eye get finer texels; the cost is rasterising tiles as the view moves.
class TiledDrape {
 public:
  /// Fails for a tile size outside [16, 4096]. Needs a current GL context.
  static Result<TiledDrape> create(int tileSize);

  struct Tile {
    int layer = 0;  ///< in colorArray() / maskArray()
    DrapeExtent extent;
  };
  struct FrameStats {
    std::size_t tilesBuilt = 0;     ///< rasterised in this frame
    double buildSeconds = 0.0;      ///< their rasterising, waited for
    std::size_t tilesResident = 0;  ///< the array's layers in use
  };

  /// Marks the start of a frame that will ask for up to `tiles` tiles: tiles asked for from now on
  /// are this frame's, and the array grows first if it holds fewer (every tile is then rebuilt).
  void beginFrame(std::size_t tiles);
  /// The tile of chunk `key` over `extent`, rasterised from `source` if it is not resident (as
  /// TextureDrape::build), in place of the least recently used tile of an earlier frame. `cache`
  /// is left consistent; the framebuffer binding is changed when a tile is built.
  Tile tile(gfx::StateCache& cache, const DrapeSource& source, std::uint64_t key, const DrapeExtent& extent,
            FrameStats& stats);
  /// Drops every tile (after a change of the shown layers).
  void invalidate();
  /// Drops the tiles whose extent meets the box [lo, hi] (after an edit there).
  void invalidate(const glm::dvec2& lo, const glm::dvec2& hi);

  [[nodiscard]] GLuint colorArray() const { return color_.id(); }
  [[nodiscard]] GLuint maskArray() const { return mask_.id(); }
  [[nodiscard]] int tileSize() const { return tileSize_; }
  [[nodiscard]] std::size_t gpuBytes() const;

 private:
  TiledDrape() = default;
  void allocate(int capacity);
  void rasterise(gfx::StateCache& cache, const DrapeSource& source, int layer, const DrapeExtent& extent);

  struct Entry {
    int layer = 0;
    DrapeExtent extent;
    std::uint64_t frame = 0;
    std::list<std::uint64_t>::iterator lru;
  };
  int tileSize_ = 256;
  int capacity_ = 0;
  std::uint64_t frame_ = 0;
  gfx::Program program_;
  gfx::TextureHandle color_, mask_;
  gfx::RenderbufferHandle stencil_;
  gfx::FramebufferHandle fbo_;
  gfx::VertexArrayHandle vao_;
  std::unordered_map<std::uint64_t, Entry> tiles_;
  std::list<std::uint64_t> lru_;  ///< most recently used first
  std::vector<int> freeLayers_;
};

}  // namespace gis::overlay
