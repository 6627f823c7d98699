// overlay_bench --mode methods: error against frame time. Every method draws the same frames of the
// fly-through in turn — terrain only, our stencil polyhedra, the seed paper's construction, texture
// draping at each size — with the error against the CPU reference (variants.cpp). Writes
// methods.json, methods.csv, methods.md (the table), methods_error_vs_time.svg and
// methods_error_away_vs_time.svg, and prints the table. overlay_bench --mode ablation: ours with
// each saving of docs/design.md §9 switched off alone, the same figures; ablation.json. Both in
// either frame (on the globe the ablation's savings of the passes only: its tiles split at their
// own cells).
#include <algorithm>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "bench_common.hpp"
#include "variants.hpp"

namespace gis::bench {

int runMethods(const Options& o) {
  std::vector<Method> methods;
  methods.emplace_back("terrain only", overlay::defaultTechnique(), 0, false);
  for (const overlay::TechniqueInfo& t : overlay::techniques()) {
    if (!t.usesTextures()) {
      methods.emplace_back(std::string(t.label), t, 0, true);
      continue;
    }
    // A texture technique at each size asked for (its name, with spaces, and the size).
    std::string name(t.name);
    std::replace(name.begin(), name.end(), '-', ' ');
    for (const int size : o.textureSizesOf(t)) methods.emplace_back(name + " " + std::to_string(size), t, size, true);
  }
  return runVariants(o, std::move(methods), "methods");
}

int runAblation(const Options& o) {
  // Each saving of docs/design.md §9 switched off alone.
  std::vector<Method> methods;
  const overlay::TechniqueInfo& ours = overlay::defaultTechnique();
  methods.emplace_back("terrain only", ours, 0, false);
  methods.emplace_back("ours (all savings)", ours, 0, true);
  const auto variant = [&](std::string name, std::function<void(overlay::OverlaySettings&)> adjust) {
    methods.emplace_back(std::move(name), ours, 0, true);
    methods.back().adjust = std::move(adjust);
  };
  variant("z-fail for every piece", [](overlay::OverlaySettings& s) { s.forceZFail = true; });
  variant("bottom caps in z-pass", [](overlay::OverlaySettings& s) { s.bottomCapsInZPass = true; });
  variant("no frustum culling", [](overlay::OverlaySettings& s) { s.cullPieces = false; });
  variant("cover with the pieces", [](overlay::OverlaySettings& s) { s.rectangleCover = false; });
  variant("one cover rectangle, no tiles", [](overlay::OverlaySettings& s) { s.tiledCover = false; });
  methods.emplace_back("split at every cell", ours, 0, true);
  methods.back().adaptiveSplit = false;
  methods.back().projectedBuild = true;
  methods.emplace_back("no split at cells", ours, 0, true);
  methods.back().cellPosts = 1 << 20;
  methods.back().projectedBuild = true;
  methods.emplace_back("lines united per cell", ours, 0, true);
  methods.back().uniteLines = true;
  methods.back().projectedBuild = true;
  return runVariants(o, std::move(methods), "ablation");
}

}  // namespace gis::bench
