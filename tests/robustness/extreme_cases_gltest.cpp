// The robustness case matrix on the GPU (docs/robustness.md): every geometry case of
// extreme_cases.hpp in one scene, on a stiff terrain from −430 m to 8,850 m (cliffs, a spike, a
// flat lake, nodata holes) and on one whose whole outside is nodata, at exaggerations 0.1×, 1×
// and 20×, seen from the extreme cameras — straight down, grazing at 0.1°, 1 m above the
// ground inside a polygon's volume, inside a road's volume, with the near plane cutting the
// volumes, exactly on a cap plane and on a wall plane, 1,000 km up — and from random ones. The
// GPU layer mask must equal the CPU reference on the same depth buffer at every pixel away from
// feature edges. Then the same scene far from the frame origin (a UTM northing near 10^7 m),
// with the position errors of the volumes and of the reference; hundreds of layers; and the
// 10^6-vertex polygon (a fifth of it under the sanitizers: sanitizer.hpp).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <random>
#include <span>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>

#include "extreme_cases.hpp"
#include "gfx/camera.hpp"
#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "overlay_compare.hpp"
#include "sanitizer.hpp"
#include "terrain/height_bounds.hpp"
#include "terrain/lod.hpp"
#include "terrain/terrain_engine.hpp"
#include "test_paths.hpp"
#include "test_terrain.hpp"
#include "vector_overlay/overlay_layer.hpp"
#include "vector_overlay/overlay_renderer.hpp"

namespace gis::test {
namespace {

using overlay_test::compare;
using overlay_test::Comparison;
using overlay_test::drawTerrainAndLayers;
using overlay_test::percent;

constexpr int kWidth = 256;
constexpr int kHeight = 192;
constexpr int kPosts = 129;
constexpr double kSpacing = 20.0;
constexpr int kChunkCells = 16;

struct NamedCamera {
  std::string name;
  glm::dvec3 eye;
  glm::dvec3 target;
  glm::dvec3 up{0.0, 0.0, 1.0};
  double fovDegrees = 50.0;
  double nearPlane = 1.0;
};

/// One terrain with the case layers built on it.
struct CaseScene {
  std::shared_ptr<const terrain::TerrainQuadtree> tree;
  std::shared_ptr<terrain::QuadtreeHeightBounds> bounds;
  std::optional<terrain::TerrainEngine> engine;
  std::vector<overlay::OverlayLayer> layers;  ///< areas, then roads with three joins and caps
  std::vector<GeometryCase> cases;
  glm::dvec2 lo{0.0}, hi{0.0};

  [[nodiscard]] std::vector<const overlay::OverlayLayer*> drawn() const {
    std::vector<const overlay::OverlayLayer*> out;
    for (const overlay::OverlayLayer& l : layers) out.push_back(&l);
    return out;
  }
  [[nodiscard]] glm::dvec2 at(double fx, double fy) const { return lo + glm::dvec2(fx, fy) * (hi - lo); }
  /// The surface height (exaggerated) at a point, or the nearest valid height found on a ring
  /// around it (nodata), or 0.
  [[nodiscard]] double ground(const glm::dvec2& p) const {
    const double h = bounds->fullResolutionHeightAt(glm::clamp(p, lo, hi));
    if (!std::isnan(h)) return h;
    for (double r = kSpacing; r < 2000.0; r *= 1.5) {
      for (int k = 0; k < 16; ++k) {
        const double a = 0.3927 * k;
        const double g =
            bounds->fullResolutionHeightAt(glm::clamp(p + r * glm::dvec2(std::cos(a), std::sin(a)), lo, hi));
        if (!std::isnan(g)) return g;
      }
    }
    return 0.0;
  }
};

CaseScene buildScene(const StiffTerrainOptions& terrainOptions) {
  CaseScene s;
  auto grid = makeStiffTerrain(terrainOptions);
  s.lo = grid->postPosition(0, grid->height - 1);
  s.hi = grid->postPosition(grid->width - 1, 0);
  s.tree = std::make_shared<terrain::TerrainQuadtree>(grid, kChunkCells);
  s.bounds = std::make_shared<terrain::QuadtreeHeightBounds>(s.tree, 1.0);
  Result<terrain::TerrainEngine> engine = terrain::TerrainEngine::create(s.tree, nullptr);
  EXPECT_TRUE(engine.ok());
  if (engine) s.engine.emplace(std::move(*engine));
  s.cases = geometryCases(s.lo, s.hi);

  overlay::LayerBuildOptions options;
  overlay::CellGrid cells;
  cells.origin = s.lo;
  cells.cellSize = kChunkCells * kSpacing;
  cells.columns = cells.rows = (kPosts - 1) / kChunkCells;
  options.footprints.cells = cells;
  std::vector<geo::Feature> areas, roads;
  std::size_t skippedAreas = 0, skippedRoads = 0, emptyAreas = 0, emptyRoads = 0;
  for (const GeometryCase& c : s.cases) {
    const bool area = c.kind == overlay::LayerKind::Polygon;
    (area ? areas : roads).push_back(c.feature);
    if (c.outcome == Outcome::Skipped) ++(area ? skippedAreas : skippedRoads);
    if (c.outcome == Outcome::NothingThere) ++(area ? emptyAreas : emptyRoads);
  }
  overlay::LayerStyle areaStyle;
  areaStyle.opacity = 0.5F;
  Result<overlay::OverlayLayer> a =
      overlay::OverlayLayer::build("areas", overlay::LayerKind::Polygon, areaStyle, areas, *s.bounds, options);
  EXPECT_TRUE(a.ok());
  if (!a) return s;
  EXPECT_EQ(a->stats().skippedFeatures, skippedAreas);
  EXPECT_EQ(a->stats().emptyFeatures, emptyAreas);
  s.layers.push_back(std::move(*a));
  const std::pair<overlay::LineJoin, overlay::LineCap> joins[] = {{overlay::LineJoin::Round, overlay::LineCap::Round},
                                                                  {overlay::LineJoin::Miter, overlay::LineCap::Square},
                                                                  {overlay::LineJoin::Bevel, overlay::LineCap::Flat}};
  for (const auto& [join, cap] : joins) {
    overlay::LayerStyle roadStyle;
    roadStyle.widthAttribute = "width_m";
    roadStyle.join = join;
    roadStyle.cap = cap;
    Result<overlay::OverlayLayer> r =
        overlay::OverlayLayer::build("roads", overlay::LayerKind::Line, roadStyle, roads, *s.bounds, options);
    EXPECT_TRUE(r.ok());
    if (!r) return s;
    EXPECT_EQ(r->stats().skippedFeatures, skippedRoads);
    // A single point with flat caps covers nothing.
    EXPECT_EQ(r->stats().emptyFeatures, emptyRoads + (cap == overlay::LineCap::Flat ? 1u : 0u));
    s.layers.push_back(std::move(*r));
  }
  return s;
}

/// The extreme cameras over a scene at the bounds' exaggeration, then `randomCount` random ones.
std::vector<NamedCamera> extremeCameras(const CaseScene& s, std::mt19937& rng, int randomCount) {
  const double top = s.bounds->globalBounds().hi;
  const glm::dvec2 centre = 0.5 * (s.lo + s.hi);
  std::vector<NamedCamera> out;
  out.push_back({"straight down, 3 km above the highest point", glm::dvec3(centre, top + 3000.0),
                 glm::dvec3(centre, 0.0), glm::dvec3(0.0, 1.0, 0.0)});
  {
    // Grazing: looking north 0.1° below the horizontal, from just above the terrain's south edge.
    const glm::dvec2 e = s.at(0.5, -0.02);
    const double h = s.ground(s.at(0.5, 0.3)) + 30.0;
    const double pitch = glm::radians(0.1);
    out.push_back({"grazing at 0.1 degrees", glm::dvec3(e, h),
                   glm::dvec3(e, h) + glm::dvec3(0.0, std::cos(pitch), -std::sin(pitch))});
  }
  {
    // 1 m above the ground, inside the volume of the polygon covering the whole DEM.
    const glm::dvec2 e = s.at(0.45, 0.62);
    const double h = s.ground(e) + 1.0;
    out.push_back({"1 m above the ground, in a polygon's volume",
                   glm::dvec3(e, h),
                   glm::dvec3(e + glm::dvec2(300.0, 200.0), s.ground(e + glm::dvec2(300.0, 200.0))),
                   {0, 0, 1},
                   60.0,
                   0.1});
  }
  {
    // On the 30 m road over 1 m segments, 2 m above the surface, looking along it.
    const glm::dvec2 e = s.at(0.57, 0.55);
    const double h = s.ground(e) + 2.0;
    out.push_back({"inside a road's volume",
                   glm::dvec3(e, h),
                   glm::dvec3(s.at(0.75, 0.55), s.ground(s.at(0.75, 0.55))),
                   {0, 0, 1},
                   60.0,
                   0.1});
  }
  {
    // The near plane (3 m) cuts the volumes under an eye 2 m above the ground.
    const glm::dvec2 e = s.at(0.15, 0.12);
    out.push_back({"near plane cutting the volumes",
                   glm::dvec3(e, s.ground(e) + 2.0),
                   glm::dvec3(e + glm::dvec2(20.0, 30.0), s.ground(e + glm::dvec2(20.0, 30.0))),
                   {0, 0, 1},
                   70.0,
                   3.0});
  }
  {
    // Exactly on the top cap plane (unpadded) of a piece of the whole-DEM polygon.
    const overlay::OverlayLayer& areas = s.layers.front();
    const glm::dvec2 e = s.at(0.33, 0.66);
    double capHeight = s.ground(e) + 10.0;
    for (const overlay::Polyhedron& p : areas.polyhedra()) {
      if (overlay::mayContain(p, glm::dvec3(e, 0.5 * (p.lo + p.hi)), 0.0, 0.0)) capHeight = p.hi;
    }
    out.push_back({"exactly on a cap plane", glm::dvec3(e, capHeight),
                   glm::dvec3(e + glm::dvec2(400.0, -100.0), s.ground(e + glm::dvec2(400.0, -100.0)))});
  }
  {
    // Exactly in the plane of a wall: x of the polygon straddling the DEM's west edge.
    const glm::dvec2 e(s.at(0.1, 0.0).x, s.at(0.0, 0.52).y);
    out.push_back({"exactly on a wall plane", glm::dvec3(e, s.ground(e) + 20.0),
                   glm::dvec3(e + glm::dvec2(0.0, 200.0), s.ground(e + glm::dvec2(0.0, 200.0)))});
  }
  out.push_back({"1,000 km up, 0.2 degree field of view",
                 glm::dvec3(centre + glm::dvec2(1000.0, -2000.0), top + 1.0e6),
                 glm::dvec3(centre, 0.0),
                 {0, 0, 1},
                 0.2,
                 1.0});
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int k = 0; k < randomCount; ++k) {
    const glm::dvec2 t = s.at(0.1 + 0.8 * unit(rng), 0.1 + 0.8 * unit(rng));
    const double a = 6.283 * unit(rng), d = 200.0 + 2500.0 * unit(rng);
    const glm::dvec2 e = t + d * glm::dvec2(std::cos(a), std::sin(a));
    const double above = s.ground(t) + (20.0 + 2000.0 * unit(rng)) * (0.2 + s.bounds->exaggeration());
    out.push_back(
        {"random " + std::to_string(k), glm::dvec3(e, std::max(above, s.ground(e) + 5.0)), glm::dvec3(t, s.ground(t))});
  }
  return out;
}

struct FrameResult {
  Comparison c;
  std::size_t zFail = 0;
};

/// Draws the scene from the camera with the renderer's stencil polyhedra, or with `technique`
/// when one is given, and compares the mask with the reference.
FrameResult drawAndCompare(gfx::StateCache& cache, gfx::RenderTarget& target, CaseScene& s,
                           overlay::OverlayRenderer& overlays, const NamedCamera& cam, const std::string& label,
                           overlay::OverlayTechnique* technique = nullptr) {
  const double fov = glm::radians(cam.fovDegrees), aspect = static_cast<double>(kWidth) / kHeight;
  const glm::dvec3 dir = glm::normalize(cam.target - cam.eye);
  const glm::dvec3 up = std::abs(glm::dot(dir, cam.up)) > 0.9999 ? glm::dvec3(0.0, 1.0, 0.0) : cam.up;
  const glm::dmat4 viewProj =
      gfx::reversedInfinitePerspective(fov, aspect, cam.nearPlane) * gfx::lookAt(cam.eye, cam.target, up);
  terrain::LodOptions lod;
  lod.pixelTolerance = 1.0;
  lod.exaggeration = s.bounds->exaggeration();
  const terrain::LodSelection selection = terrain::selectLod(*s.tree, {cam.eye, viewProj, kHeight, fov}, lod);
  const overlay::OverlayView view{viewProj, cam.eye, cam.nearPlane, fov, aspect};
  const auto stats = technique != nullptr
                         ? overlay_test::drawTerrainAndTechnique(cache, target, *s.engine, *technique, selection, view,
                                                                 s.drawn(), {}, s.bounds->exaggeration())
                         : drawTerrainAndLayers(cache, target, *s.engine, overlays, selection, view, s.drawn(), {},
                                                s.bounds->exaggeration());
  FrameResult r;
  for (const auto& l : stats) r.zFail += l.zFailPieces;
  r.c = compare(target, viewProj, s.drawn(), label);
  return r;
}

std::filesystem::path outputDir() {
  std::filesystem::path dir(STENCIL_GIS_TEST_OUTPUT_DIR);
  std::filesystem::create_directories(dir);
  return dir;
}

class ExtremeCasesGlTest : public GlTest {};

/// The case matrix with the renderer's stencil polyhedra, or with the deferred technique.
void everyCaseFromEveryExtremeCamera(gfx::StateCache& cache_, bool deferred) {
  struct TerrainRow {
    const char* name;
    StiffTerrainOptions options;
  };
  const TerrainRow terrains[] = {
      {"stiff, -430 m to 8,850 m, holes",
       {.width = kPosts, .height = kPosts, .spacing = kSpacing, .seed = 5, .lowest = -430.0, .highest = 8850.0}},
      {"nodata border and holes",
       {.width = kPosts, .height = kPosts, .spacing = kSpacing, .seed = 9, .nodataBorder = true}},
  };
  Result<overlay::OverlayRenderer> overlays = overlay::OverlayRenderer::create();
  ASSERT_TRUE(overlays.ok());
  std::unique_ptr<overlay::OverlayTechnique> technique;
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  nlohmann::json rows = nlohmann::json::array();
  Comparison total;
  std::printf("%-34s %5s  %-46s %8s %6s %6s %6s\n", "terrain", "exag", "camera", "covered", "wrong", "edge", "z-fail");
  for (const TerrainRow& row : terrains) {
    CaseScene scene = buildScene(row.options);
    ASSERT_TRUE(scene.engine && scene.layers.size() == 4);
    for (const overlay::OverlayLayer& l : scene.layers) {
      const overlay::LayerValidation v = l.validate();
      EXPECT_TRUE(v.problems.empty()) << (v.problems.empty() ? "" : v.problems.items().front().toString());
    }
    if (deferred) technique = overlay_test::deferredTechnique(scene.bounds.get());
    std::mt19937 rng(11);
    for (double exaggeration : {0.1, 1.0, 20.0}) {
      if (technique) technique->invalidate();  // the index's heights follow the exaggeration
      scene.bounds->setExaggeration(exaggeration);
      for (overlay::OverlayLayer& l : scene.layers) l.refreshBounds(*scene.bounds);
      for (const NamedCamera& cam : extremeCameras(scene, rng, 4)) {
        const std::string label = std::string(row.name) + " / " + std::to_string(exaggeration) + "x / " + cam.name;
        const FrameResult r = drawAndCompare(cache_, target, scene, *overlays, cam, label, technique.get());
        total.covered += r.c.covered;
        total.wrong += r.c.wrong;
        total.edgeWrong += r.c.edgeWrong;
        std::printf("%-34s %5.1f  %-46s %8zu %6zu %6zu %6zu\n", row.name, exaggeration, cam.name.c_str(), r.c.covered,
                    r.c.wrong, r.c.edgeWrong, r.zFail);
        rows.push_back({{"terrain", row.name},
                        {"exaggeration", exaggeration},
                        {"camera", cam.name},
                        {"covered", r.c.covered},
                        {"wrong", r.c.wrong},
                        {"edge_wrong", r.c.edgeWrong},
                        {"z_fail_pieces", r.zFail}});
      }
    }
  }
  std::ofstream(outputDir() / (deferred ? "extreme_cameras_deferred.json" : "extreme_cameras.json"))
      << rows.dump(1) << "\n";
  std::printf("%s: %zu covered pixels, %zu wrong away from edges, %zu on edges (%.3f %%)\n",
              deferred ? "deferred" : "stencil", total.covered, total.wrong, total.edgeWrong,
              percent(total.edgeWrong, total.covered));
  EXPECT_EQ(total.wrong, 0u);
  EXPECT_LE(total.edgeWrong, total.covered / 100);
  EXPECT_GT(total.covered, 200000u);
}

TEST_F(ExtremeCasesGlTest, EveryCaseFromEveryExtremeCameraMatchesTheReference) {
  everyCaseFromEveryExtremeCamera(cache_, false);
}

TEST_F(ExtremeCasesGlTest, TheDeferredTechniqueMatchesTheReferenceFromEveryExtremeCamera) {
  everyCaseFromEveryExtremeCamera(cache_, true);
}

TEST_F(ExtremeCasesGlTest, FarFromTheFrameOriginThePixelsAndPositionsHold) {
  // The same scene and cameras with the data at the frame origin and at a UTM-like position
  // (easting 500 km, northing 9,900 km) with the frame origin left at 0: the GPU masks must
  // match the reference in both, and the unprojected terrain points must agree once shifted.
  const glm::dvec2 offset(500000.0, 9900000.0);
  Result<overlay::OverlayRenderer> overlays = overlay::OverlayRenderer::create();
  ASSERT_TRUE(overlays.ok());
  StiffTerrainOptions o{.width = kPosts, .height = kPosts, .spacing = kSpacing, .seed = 5};
  CaseScene nearScene = buildScene(o);
  o.centre = offset;
  CaseScene farScene = buildScene(o);
  ASSERT_TRUE(nearScene.engine && farScene.engine);
  double volumeError[2] = {0.0, 0.0};
  for (int k = 0; k < 2; ++k) {
    for (const overlay::OverlayLayer& l : (k == 0 ? nearScene : farScene).layers) {
      const overlay::LayerValidation v = l.validate();
      EXPECT_TRUE(v.problems.empty());
      volumeError[k] = std::max(volumeError[k], v.maxPositionError);
    }
  }
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  std::mt19937 rngNear(5), rngFar(5);
  const std::vector<NamedCamera> camerasNear = extremeCameras(nearScene, rngNear, 6);
  const std::vector<NamedCamera> camerasFar = extremeCameras(farScene, rngFar, 6);
  ASSERT_EQ(camerasNear.size(), camerasFar.size());
  double worstShift = 0.0, worstRelative = 0.0, worstStep = 0.0, worstStepRelative = 0.0;
  std::size_t maskDifferences = 0, compared = 0;
  Comparison total;
  for (std::size_t k = 0; k < camerasNear.size(); ++k) {
    std::vector<float> depth[2];
    std::vector<std::uint32_t> mask[2];
    glm::dmat4 viewProj[2];
    for (int which = 0; which < 2; ++which) {
      CaseScene& scene = which == 0 ? nearScene : farScene;
      const NamedCamera& cam = which == 0 ? camerasNear[k] : camerasFar[k];
      const FrameResult r = drawAndCompare(cache_, target, scene, *overlays, cam,
                                           std::string(which == 0 ? "near / " : "far / ") + cam.name);
      total.covered += r.c.covered;
      total.wrong += r.c.wrong;
      total.edgeWrong += r.c.edgeWrong;
      depth[which] = gfx::readDepth(target);
      mask[which] = gfx::readMask(target);
      const double fov = glm::radians(cam.fovDegrees);
      const glm::dvec3 dir = glm::normalize(cam.target - cam.eye);
      const glm::dvec3 up = std::abs(glm::dot(dir, cam.up)) > 0.9999 ? glm::dvec3(0.0, 1.0, 0.0) : cam.up;
      viewProj[which] = gfx::reversedInfinitePerspective(fov, static_cast<double>(kWidth) / kHeight, cam.nearPlane) *
                        gfx::lookAt(cam.eye, cam.target, up);
    }
    const overlay::DepthImage nearImage{kWidth, kHeight, depth[0], viewProj[0]};
    const overlay::DepthImage farImage{kWidth, kHeight, depth[1], viewProj[1]};
    std::vector<float> stepped = depth[1];
    const overlay::DepthImage steppedImage{kWidth, kHeight, stepped, viewProj[1]};
    for (int y = 1; y + 1 < kHeight; ++y) {
      for (int x = 1; x + 1 < kWidth; ++x) {
        const std::size_t i = static_cast<std::size_t>(y * kWidth + x);
        maskDifferences += mask[0][i] != mask[1][i] ? 1u : 0u;
        // Away from depth discontinuities: the pixel and its neighbours within 5 % of each other
        // in both images (the same surface seen at both positions).
        bool smooth = depth[0][i] > 0.0F && depth[1][i] > 0.0F;
        for (int dy = -1; dy <= 1 && smooth; ++dy) {
          for (int dx = -1; dx <= 1 && smooth; ++dx) {
            const std::size_t j = static_cast<std::size_t>((y + dy) * kWidth + x + dx);
            for (int which = 0; which < 2; ++which) {
              smooth = smooth && std::abs(depth[which][j] - depth[which][i]) <= 0.05F * depth[which][i];
            }
          }
        }
        if (!smooth) continue;
        const std::optional<glm::dvec3> a = overlay::unprojectPixel(nearImage, x, y);
        const std::optional<glm::dvec3> b = overlay::unprojectPixel(farImage, x, y);
        if (!a || !b) continue;
        ++compared;
        // The reference's own resolution there: the point one float step of depth away.
        stepped[i] = std::nextafter(depth[1][i], 2.0F);
        if (const std::optional<glm::dvec3> c = overlay::unprojectPixel(steppedImage, x, y)) {
          worstStep = std::max(worstStep, glm::length(*c - *b));
          worstStepRelative = std::max(worstStepRelative, glm::length(*c - *b) / glm::length(*b - camerasFar[k].eye));
        }
        stepped[i] = depth[1][i];
        const double shift = glm::length(*b - glm::dvec3(offset, 0.0) - *a);
        worstShift = std::max(worstShift, shift);
        worstRelative = std::max(worstRelative, shift / glm::length(*a - camerasNear[k].eye));
      }
    }
  }
  std::printf(
      "far from the origin: volumes' vertex error %.2e m (near the origin %.2e m); reference points moved "
      "by at most %.3g m (%.2e of the distance) over %zu pixels; one float step of depth moves a reference "
      "point by up to %.3g m (%.2e of the distance); %zu of %zu mask pixels differ; %zu wrong, "
      "%zu on edges of %zu covered\n",
      volumeError[1], volumeError[0], worstShift, worstRelative, compared, worstStep, worstStepRelative,
      maskDifferences, camerasNear.size() * static_cast<std::size_t>(kWidth * kHeight), total.wrong, total.edgeWrong,
      total.covered);
  nlohmann::json j{{"volume_vertex_error_m", volumeError[1]},
                   {"volume_vertex_error_near_origin_m", volumeError[0]},
                   {"reference_point_shift_m", worstShift},
                   {"reference_point_shift_relative", worstRelative},
                   {"pixels_compared", compared},
                   {"reference_depth_step_m", worstStep},
                   {"reference_depth_step_relative", worstStepRelative},
                   {"mask_pixels_differing", maskDifferences},
                   {"wrong", total.wrong},
                   {"edge_wrong", total.edgeWrong},
                   {"covered", total.covered}};
  std::ofstream(outputDir() / "far_from_origin.json") << j.dump(1) << "\n";
  EXPECT_EQ(total.wrong, 0u);
  // Vertices are floats relative to a 1 km grid of origins: within 2^-24 of 1.5 km.
  EXPECT_LT(volumeError[1], 1e-4);
  // Depth is a float: a point moves by about 2^-24 of its distance, twice; 1e-5 of it at most.
  EXPECT_LT(worstRelative, 1e-5);
  EXPECT_GT(compared, 100000u);
}

TEST_F(ExtremeCasesGlTest, TheDeferredTechniqueHoldsFarFromTheFrameOrigin) {
  // The deferred technique finds ground points as integer cells plus a float remainder: with the
  // data at a UTM-like position (easting 500 km, northing 9,900 km) and the frame origin at 0,
  // it must still match the reference at every pixel away from edges.
  Result<overlay::OverlayRenderer> overlays = overlay::OverlayRenderer::create();
  ASSERT_TRUE(overlays.ok());
  StiffTerrainOptions o{.width = kPosts, .height = kPosts, .spacing = kSpacing, .seed = 5};
  o.centre = glm::dvec2(500000.0, 9900000.0);
  CaseScene farScene = buildScene(o);
  ASSERT_TRUE(farScene.engine);
  std::unique_ptr<overlay::OverlayTechnique> technique = overlay_test::deferredTechnique(farScene.bounds.get());
  ASSERT_TRUE(technique);
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  std::mt19937 rng(5);
  Comparison total;
  for (const NamedCamera& cam : extremeCameras(farScene, rng, 6)) {
    const FrameResult r =
        drawAndCompare(cache_, target, farScene, *overlays, cam, "far / " + cam.name, technique.get());
    total.covered += r.c.covered;
    total.wrong += r.c.wrong;
    total.edgeWrong += r.c.edgeWrong;
  }
  std::printf("deferred far from the origin: %zu covered pixels, %zu wrong away from edges, %zu on edges\n",
              total.covered, total.wrong, total.edgeWrong);
  EXPECT_EQ(total.wrong, 0u);
  EXPECT_LE(total.edgeWrong, total.covered / 100);
  EXPECT_GT(total.covered, 50000u);
}

TEST_F(ExtremeCasesGlTest, HundredsOfLayersEachColourExactlyTheirPixels) {
  // 300 layers of one opaque polygon each, overlapping in a fan over the stiff terrain: every
  // pixel shows the colour of the last layer covering it (or the terrain). The mask holds 32
  // layers; colours check them all.
  constexpr int kLayers = 300;
  auto grid = makeStiffTerrain({.width = kPosts, .height = kPosts, .spacing = kSpacing, .seed = 13});
  const glm::dvec2 lo = grid->postPosition(0, grid->height - 1), hi = grid->postPosition(grid->width - 1, 0);
  auto tree = std::make_shared<terrain::TerrainQuadtree>(grid, kChunkCells);
  auto bounds = std::make_shared<terrain::QuadtreeHeightBounds>(tree, 1.0);
  Result<terrain::TerrainEngine> engine = terrain::TerrainEngine::create(tree, nullptr);
  Result<overlay::OverlayRenderer> overlays = overlay::OverlayRenderer::create();
  ASSERT_TRUE(engine.ok() && overlays.ok());
  overlay::LayerBuildOptions options;
  options.footprints.cells =
      overlay::CellGrid{lo, kChunkCells * kSpacing, (kPosts - 1) / kChunkCells, (kPosts - 1) / kChunkCells};
  const glm::dvec2 centre = 0.5 * (lo + hi);
  std::vector<overlay::OverlayLayer> layers;
  std::vector<std::array<std::uint8_t, 3>> colours;
  for (int k = 0; k < kLayers; ++k) {
    geo::Feature f;
    f.fid = k;
    geo::Polygon p;  // a thin wedge from near the centre, turning with k, plus a disc of radius k
    const double a = 6.283185307179586 * k / kLayers, r = 1200.0;
    p.outer = {centre + 40.0 * glm::dvec2(std::cos(a + 1.7), std::sin(a + 1.7)),
               centre + r * glm::dvec2(std::cos(a - 0.15), std::sin(a - 0.15)),
               centre + r * glm::dvec2(std::cos(a + 0.15), std::sin(a + 0.15))};
    f.polygons.push_back(std::move(p));
    const std::array<std::uint8_t, 3> rgb{static_cast<std::uint8_t>(k % 256),
                                          static_cast<std::uint8_t>(40 + 60 * (k / 256)),
                                          static_cast<std::uint8_t>((k * 7) % 256)};
    colours.push_back(rgb);
    overlay::LayerStyle style;
    style.color = glm::vec4(rgb[0] / 255.0F, rgb[1] / 255.0F, rgb[2] / 255.0F, 1.0F);
    style.opacity = 1.0F;
    Result<overlay::OverlayLayer> layer = overlay::OverlayLayer::build(
        "layer " + std::to_string(k), overlay::LayerKind::Polygon, style, {f}, *bounds, options);
    ASSERT_TRUE(layer.ok());
    layers.push_back(std::move(*layer));
  }
  std::vector<const overlay::OverlayLayer*> drawn;
  for (const overlay::OverlayLayer& l : layers) drawn.push_back(&l);

  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  gfx::RenderTarget terrainOnly(kWidth, kHeight, 0, true);
  std::size_t checked = 0, wrong = 0;
  std::vector<std::uint8_t> seen(kLayers, 0);  // layers on top at some checked pixel
  // The stencil polyhedra, then the deferred technique (300 layers: two passes of its uniform
  // block of 256 layers).
  std::unique_ptr<overlay::OverlayTechnique> deferred = overlay_test::deferredTechnique(bounds.get());
  ASSERT_TRUE(deferred);
  const std::array<glm::dvec3, 3> offsets{glm::dvec3(0.0, -10.0, 3500.0), glm::dvec3(-1800.0, -1300.0, 1400.0),
                                          glm::dvec3(0.0, -5.0, 1500.0)};
  for (std::size_t view = 0; view < 2 * offsets.size(); ++view) {
    overlay::OverlayTechnique* technique = view < offsets.size() ? nullptr : deferred.get();
    const glm::dvec3 eye = glm::dvec3(centre, 0.0) + offsets[view % offsets.size()];
    const double fov = glm::radians(50.0), aspect = static_cast<double>(kWidth) / kHeight;
    const glm::dmat4 viewProj =
        gfx::reversedInfinitePerspective(fov, aspect, 1.0) * gfx::lookAt(eye, glm::dvec3(centre, 0.0), {0, 0, 1});
    const terrain::LodSelection selection = terrain::selectLod(*tree, {eye, viewProj, kHeight, fov});
    drawTerrainAndLayers(cache_, terrainOnly, *engine, *overlays, selection, {viewProj, eye, 1.0, fov, aspect}, {});
    if (technique != nullptr) {
      overlay_test::drawTerrainAndTechnique(cache_, target, *engine, *technique, selection,
                                            {viewProj, eye, 1.0, fov, aspect}, drawn);
    } else {
      drawTerrainAndLayers(cache_, target, *engine, *overlays, selection, {viewProj, eye, 1.0, fov, aspect}, drawn);
    }
    const std::vector<std::uint8_t> background = gfx::readColorRgba8(terrainOnly);
    const std::vector<std::uint8_t> colour = gfx::readColorRgba8(target);
    const std::vector<float> depth = gfx::readDepth(target);
    const overlay::DepthImage image{kWidth, kHeight, depth, viewProj};
    std::vector<overlay::ReferenceLayer> ref;
    for (const overlay::OverlayLayer& l : layers) ref.push_back(overlay::referenceLayerOf(l));
    // Edge pixels of any layer may differ; compute them 32 layers at a time.
    std::vector<std::uint8_t> edge(static_cast<std::size_t>(kWidth * kHeight), 0);
    for (std::size_t first = 0; first < ref.size(); first += 32) {
      const std::span<const overlay::ReferenceLayer> part(ref.data() + first,
                                                          std::min<std::size_t>(32, ref.size() - first));
      const std::vector<std::uint8_t> e = overlay::edgePixels(image, part);
      for (std::size_t i = 0; i < e.size(); ++i) edge[i] = static_cast<std::uint8_t>(edge[i] | e[i]);
    }
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        const std::size_t i = static_cast<std::size_t>(y * kWidth + x);
        if (edge[i] != 0) continue;
        const std::optional<glm::dvec3> p = overlay::unprojectPixel(image, x, y);
        std::optional<int> top;
        if (p) {
          for (int k = kLayers - 1; k >= 0 && !top; --k) {
            if (overlay::coveringFeature(ref[static_cast<std::size_t>(k)], glm::dvec2(*p))) top = k;
          }
        }
        // Read-back rows are the image's rows from the top, like the depth.
        const std::uint8_t* got = &colour[4 * i];
        const std::uint8_t* want = top ? colours[static_cast<std::size_t>(*top)].data() : &background[4 * i];
        if (top) seen[static_cast<std::size_t>(*top)] = 1;
        ++checked;
        if (std::abs(got[0] - want[0]) > 1 || std::abs(got[1] - want[1]) > 1 || std::abs(got[2] - want[2]) > 1) {
          if (wrong++ < 5) {
            ADD_FAILURE() << (technique != nullptr ? "deferred" : "stencil") << ": pixel (" << x << ", " << y
                          << "): colour " << int(got[0]) << "," << int(got[1]) << "," << int(got[2])
                          << ", expected layer " << (top ? *top : -1);
          }
        }
      }
    }
  }
  const auto layersSeen = static_cast<std::size_t>(std::count(seen.begin(), seen.end(), 1));
  std::printf("%d layers: %zu pixels checked, %zu wrong, %zu layers on top somewhere\n", kLayers, checked, wrong,
              layersSeen);
  EXPECT_EQ(wrong, 0u);
  EXPECT_GT(checked, 80000u);
  EXPECT_GT(layersSeen, 100u);
}

TEST_F(ExtremeCasesGlTest, EmptyLayersBuildAndDrawNothing) {
  auto tree = std::make_shared<terrain::TerrainQuadtree>(
      makeStiffTerrain({.width = kPosts, .height = kPosts, .spacing = kSpacing, .seed = 19}), kChunkCells);
  auto bounds = std::make_shared<terrain::QuadtreeHeightBounds>(tree, 1.0);
  Result<terrain::TerrainEngine> engine = terrain::TerrainEngine::create(tree, nullptr);
  Result<overlay::OverlayRenderer> overlays = overlay::OverlayRenderer::create();
  ASSERT_TRUE(engine.ok() && overlays.ok());
  Result<overlay::OverlayLayer> polygons =
      overlay::OverlayLayer::build("no areas", overlay::LayerKind::Polygon, {}, {}, *bounds);
  Result<overlay::OverlayLayer> lines =
      overlay::OverlayLayer::build("no roads", overlay::LayerKind::Line, {}, {}, *bounds);
  ASSERT_TRUE(polygons.ok() && lines.ok());
  EXPECT_TRUE(polygons.diagnostics.empty() && lines.diagnostics.empty());
  EXPECT_EQ(polygons->stats().pieces + lines->stats().pieces, 0u);
  EXPECT_TRUE(polygons->validate().problems.empty());
  const std::vector<const overlay::OverlayLayer*> drawn{&*polygons, &*lines};
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  const glm::dvec3 eye(0.0, -1500.0, 1800.0);
  const double fov = glm::radians(50.0), aspect = static_cast<double>(kWidth) / kHeight;
  const glm::dmat4 viewProj =
      gfx::reversedInfinitePerspective(fov, aspect, 1.0) * gfx::lookAt(eye, glm::dvec3(0.0), {0, 0, 1});
  drawTerrainAndLayers(cache_, target, *engine, *overlays, terrain::selectLod(*tree, {eye, viewProj, kHeight, fov}),
                       {viewProj, eye, 1.0, fov, aspect}, drawn);
  const Comparison c = compare(target, viewProj, drawn, "empty layers");
  EXPECT_EQ(c.covered + c.wrong + c.edgeWrong, 0u);
  const std::vector<std::uint32_t> mask = gfx::readMask(target);
  EXPECT_EQ(std::count(mask.begin(), mask.end(), 0u), static_cast<long>(mask.size()));
}

TEST_F(ExtremeCasesGlTest, AMillionVertexPolygonMatchesTheReference) {
  auto grid = makeStiffTerrain({.width = kPosts, .height = kPosts, .spacing = kSpacing, .seed = 17});
  const glm::dvec2 lo = grid->postPosition(0, grid->height - 1), hi = grid->postPosition(grid->width - 1, 0);
  auto tree = std::make_shared<terrain::TerrainQuadtree>(grid, kChunkCells);
  auto bounds = std::make_shared<terrain::QuadtreeHeightBounds>(tree, 1.0);
  Result<terrain::TerrainEngine> engine = terrain::TerrainEngine::create(tree, nullptr);
  Result<overlay::OverlayRenderer> overlays = overlay::OverlayRenderer::create();
  ASSERT_TRUE(engine.ok() && overlays.ok());
  overlay::LayerBuildOptions options;
  options.footprints.cells =
      overlay::CellGrid{lo, kChunkCells * kSpacing, (kPosts - 1) / kChunkCells, (kPosts - 1) / kChunkCells};
  const glm::dvec2 centre = 0.5 * (lo + hi);
  Result<overlay::OverlayLayer> layer = overlay::OverlayLayer::build(
      "big", overlay::LayerKind::Polygon, {}, {starPolygon(centre, 0.45 * (hi.x - lo.x), kStressPolygonVertices)},
      *bounds, options);
  ASSERT_TRUE(layer.ok());
  EXPECT_TRUE(layer->validate().problems.empty());
  const std::vector<const overlay::OverlayLayer*> drawn{&*layer};
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  Comparison total;
  for (const glm::dvec3& offset : {glm::dvec3(0.0, -10.0, 3000.0), glm::dvec3(-900.0, -700.0, 600.0)}) {
    const glm::dvec3 eye = glm::dvec3(centre, 0.0) + offset;
    const double fov = glm::radians(50.0), aspect = static_cast<double>(kWidth) / kHeight;
    const glm::dmat4 viewProj =
        gfx::reversedInfinitePerspective(fov, aspect, 1.0) * gfx::lookAt(eye, glm::dvec3(centre, 0.0), {0, 0, 1});
    drawTerrainAndLayers(cache_, target, *engine, *overlays, terrain::selectLod(*tree, {eye, viewProj, kHeight, fov}),
                         {viewProj, eye, 1.0, fov, aspect}, drawn);
    const Comparison c = compare(target, viewProj, drawn, "the big polygon");
    total.covered += c.covered;
    total.wrong += c.wrong;
    total.edgeWrong += c.edgeWrong;
  }
  std::printf("%d-vertex polygon: %zu pieces, %zu triangles, built in %.1f s; %zu covered, %zu wrong, %zu on edges\n",
              kStressPolygonVertices, layer->stats().pieces, layer->stats().triangles, layer->stats().buildSeconds,
              total.covered, total.wrong, total.edgeWrong);
  EXPECT_EQ(total.wrong, 0u);
  EXPECT_GT(total.covered, 30000u);
}

}  // namespace
}  // namespace gis::test
