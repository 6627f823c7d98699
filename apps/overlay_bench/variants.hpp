#pragma once
// The engine of the methods, ablation and scaling modes: variants of the overlay drawn on the same
// frames, timed, and judged against the CPU reference.
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bench_common.hpp"
#include "scene/frame_renderer.hpp"

namespace gis::bench {

/// What one method measured over some frames (the whole path, or one of its segments).
struct Tally {
  std::vector<double> ms;     ///< wall time per frame, glFinish to glFinish
  std::vector<double> ratio;  ///< frame time over terrain only, per frame
  std::size_t pixels = 0, wrong = 0, pixelsAway = 0, wrongAway = 0;
  std::size_t covered = 0;  ///< pixels the reference covers, over the judged frames
  std::uint64_t markFragments = 0,
                coverFragments = 0;  ///< over the judged frames
  std::uint64_t markTriangles = 0, coverTriangles = 0;
  std::size_t zFailPieces = 0, drawnPieces = 0;
  std::vector<double> terrainGpuMs, markGpuMs,
      coverGpuMs;  ///< per judged frame (GPU timer queries)

  [[nodiscard]] std::uint64_t fragments() const { return markFragments + coverFragments; }
  [[nodiscard]] double wrongPct() const {
    return pixels > 0 ? 100.0 * static_cast<double>(wrong) / static_cast<double>(pixels) : 0.0;
  }
  [[nodiscard]] double wrongAwayPct() const {
    return pixelsAway > 0 ? 100.0 * static_cast<double>(wrongAway) / static_cast<double>(pixelsAway) : 0.0;
  }
  /// Adds another tally's frames and counts.
  void add(const Tally& t);
};

struct Method {
  Method(std::string n, const overlay::TechniqueInfo& t, int size, bool withOverlays)
      : name(std::move(n)), technique(&t), drapeSize(size), overlays(withOverlays) {}
  std::string name;
  const overlay::TechniqueInfo* technique = nullptr;
  int drapeSize = 0;  ///< texture techniques: texels per side
  bool overlays = true;
  int cellPosts = 16;         ///< pieces split at cells of this many DEM posts (the ablation turns it off)
  bool adaptiveSplit = true;  ///< the split kept only where it pays (the ablation splits everywhere)
  bool uniteLines = false;    ///< a line feature's shapes united per cell (the ablation's comparison)
  /// It changes how a projected frame builds its pieces (cellPosts, adaptiveSplit, uniteLines):
  /// left out on the globe, whose tiles split at their own cells.
  bool projectedBuild = false;
  std::function<void(overlay::OverlaySettings&)> adjust;  ///< the ablation's switch, if any
  std::unique_ptr<scene::FrameRenderer> renderer;         ///< its own, or null when it shares another's
  scene::FrameRenderer* shared = nullptr;                 ///< the renderer it draws with
  Tally all;
  std::map<std::string, Tally> segments;
  std::size_t gpuBytes = 0;
  std::size_t triangles = 0;   ///< of the built polyhedra
  double buildSeconds = 0.0;   ///< polyhedra or drape build; for tiles, all tiles of the path
  std::size_t tilesBuilt = 0;  ///< DrapeTiles: tiles rasterised over the path
  bool firstDrawn = false;     ///< layers built by the first frame (an index, the globe's pieces): it was drawn
  double editMs = 0.0;         ///< a one-feature edit: pieces rebuilt, and the drape (tiles) again
};

/// Draws every variant on the methods path of o.scene (in its frame: projected or on the globe), prints and writes the
/// tables and plots (stem.json, .csv, .md, _error*_vs_time.svg); the result JSON also into `result` if given.
/// variants[0] is terrain only and variants[1] ours, the base of the ratios.
int runVariants(const Options& o, std::vector<Method> variants, const std::string& stem, json* result = nullptr);

/// The tables, printed and as stem.md, and the plots of error against frame time
/// (variants_report.cpp).
void reportVariants(const Options& o, const std::vector<Method>& methods, const std::string& stem);

/// A method's tally as JSON, with its fragments against ours over the same frames.
json tallyJson(const Tally& t, const Tally& ours, bool overlays);

/// Median of a list, 0 for none.
inline double median(const std::vector<double>& v) { return percentile(v, 50); }

}  // namespace gis::bench
