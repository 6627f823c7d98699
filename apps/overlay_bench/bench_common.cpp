#include "bench_common.hpp"

#include <cmath>
#include <numbers>

namespace gis::bench {

std::size_t processMemory(const char* key) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind(key, 0) == 0) return static_cast<std::size_t>(std::stoull(line.substr(line.find(':') + 1))) * 1024;
  }
  return 0;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(
      std::clamp(p / 100.0 * static_cast<double>(v.size() - 1), 0.0, static_cast<double>(v.size() - 1)) + 0.5);
  return v[std::min(i, v.size() - 1)];
}

int finish(const Options& o, const nlohmann::json& result, gfx::Context& context) {
  std::ofstream(std::filesystem::path(o.out) / "bench.json") << result.dump(2) << '\n';
  std::printf("%s\n", result.dump(2).c_str());
  return context.debug().errorCount() == 0 ? 0 : 1;
}

std::optional<BenchSetup> setUp(const Options& o, bool withLayers) {
  const auto start = std::chrono::steady_clock::now();
  Result<scene::SceneDescription> description = scene::loadSceneFile(o.scene);
  app::report(description.diagnostics);
  if (!description) return std::nullopt;
  if (!withLayers) description->layers.clear();
  scene::LoadOptions loadOptions;
  loadOptions.paging = o.paging;
  Result<scene::LoadedScene> scene = scene::loadScene(*description, loadOptions);
  app::report(scene.diagnostics);
  if (!scene) return std::nullopt;
  const double loadSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  Result<std::unique_ptr<gfx::Context>> context = gfx::createHeadlessContext({});
  app::report(context.diagnostics);
  if (!context) return std::nullopt;
  return BenchSetup{std::move(*description), std::move(*scene), std::move(*context), loadSeconds};
}

scene::RenderSettings comparisonSettings(const Options& o) {
  scene::RenderSettings settings;
  settings.lodTolerancePixels = o.lodTolerance;
  settings.waitForTiles = true;
  return settings;
}

std::vector<scene::PathFrame> flyThroughOf(const Options& o, const BenchSetup& setup) {
  glm::dvec3 lo, hi;
  scene::terrainBox(setup.scene, setup.description.verticalExaggeration, lo, hi);
  return scene::flyThrough(lo, hi, o.frames);
}

double msSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

std::vector<scene::PathFrame> closeUpPath(const BenchSetup& setup, int frames) {
  struct Spot {
    glm::dvec2 point, direction;
  };
  std::vector<Spot> roads, areas;
  for (const scene::LoadedLayer& layer : setup.scene.layers) {
    for (const geo::Feature& f : layer.features.all()) {
      for (const geo::LineString& line : f.lines) {
        const std::size_t i = line.size() / 2;
        if (i == 0) continue;
        const glm::dvec2 d = line[i] - line[i - 1];
        if (glm::length(d) > 0.0) roads.push_back({0.5 * (line[i] + line[i - 1]), glm::normalize(d)});
      }
      for (const geo::Polygon& p : f.polygons) {
        if (p.outer.size() < 3) continue;
        glm::dvec2 c(0.0);
        for (const glm::dvec2& v : p.outer) c += v;
        areas.push_back({c / static_cast<double>(p.outer.size()), glm::dvec2(1.0, 0.0)});
      }
    }
  }
  std::vector<scene::PathFrame> path;
  const auto& bounds = *setup.scene.bounds;
  for (int k = 0; k < frames * 4 && static_cast<int>(path.size()) < frames; ++k) {
    const std::vector<Spot>& list = (k % 2 == 0 && !roads.empty()) || areas.empty() ? roads : areas;
    if (list.empty()) break;
    // Spread over the list: a fixed stride through it.
    const Spot& spot = list[(static_cast<std::size_t>(k) * 7919u) % list.size()];
    const double ground = bounds.fullResolutionHeightAt(spot.point);
    if (!std::isfinite(ground)) continue;
    scene::Camera c;
    c.eye = glm::dvec3(spot.point, ground + 1.5);
    const double down = 10.0 * std::numbers::pi / 180.0;
    c.target = c.eye + glm::dvec3(std::cos(down) * spot.direction, -std::sin(down));
    c.nearPlane = 0.1;
    path.push_back({c, "close-up"});
  }
  return path;
}

std::vector<scene::PathFrame> methodsPath(const Options& o, const BenchSetup& setup) {
  std::vector<scene::PathFrame> all = flyThroughOf(o, setup);
  const std::vector<scene::PathFrame> close = closeUpPath(setup, std::max(o.frames / 3, 1));
  all.insert(all.end(), close.begin(), close.end());
  if (o.segments.empty()) return all;
  std::vector<scene::PathFrame> kept;
  for (scene::PathFrame& f : all) {
    if (std::find(o.segments.begin(), o.segments.end(), f.segment) != o.segments.end()) kept.push_back(std::move(f));
  }
  return kept;
}

}  // namespace gis::bench
