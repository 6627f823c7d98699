#include "bench_common.hpp"

#include <cstdio>

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
  Result<scene::Scene> scene = scene::Scene::load(*description, loadOptions);
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
  scene::terrainBox(setup.scene.projected(), setup.description.verticalExaggeration, lo, hi);
  return scene::flyThrough(lo, hi, o.frames);
}

double msSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace gis::bench
