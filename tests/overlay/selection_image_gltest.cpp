// Image tests of lasso selection (docs/design.md §6–§7): the colour the GPU writes for highlight, Invert
// and "show volumes", pixel by pixel against the CPU twin evaluated on the same depth buffer.
// - Highlight: selected pixels take the style's colour blended over the terrain, every other
//   pixel (background included) keeps its colour bit for bit, the stencil ends at 0.
// - Invert: at the end and in the middle of a chain; geometry outside every volume becomes
//   selected, background never changes.
// - Show volumes: a pixel changes iff its view ray meets a face of a volume in front of the
//   terrain (a CPU rasterisation in double of the homogeneous volume triangles), by exactly as
//   many blends as faces it meets; unchanged pixels are bit-identical.
// Pixels within a hair of a volume's boundary (highlight, Invert: selection_gltest's criterion;
// show volumes: within 0.05 pixel of a projected face edge, or where a face meets the terrain) may
// go either way; they are counted, not checked.
// The images go to STENCIL_GIS_TEST_OUTPUT_DIR for inspection.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include "gfx/camera.hpp"
#include "gfx/image_io.hpp"
#include "gfx/render_target.hpp"
#include "selection_scene.hpp"
#include "terrain/height_bounds.hpp"
#include "terrain/lod.hpp"
#include "terrain/terrain_engine.hpp"
#include "test_paths.hpp"
#include "test_terrain.hpp"
#include "vector_overlay/lasso.hpp"
#include "vector_overlay/selection_renderer.hpp"
#include "vector_overlay/selection_states.hpp"

namespace gis::test {
namespace {

constexpr int kWidth = kSelectionWidth;
constexpr int kHeight = kSelectionHeight;
constexpr std::size_t kPixels = static_cast<std::size_t>(kWidth) * static_cast<std::size_t>(kHeight);
const double kFov = selectionFov();
const glm::vec4 kBackground{0.1F, 0.1F, 0.1F, 1.0F};

/// Highlight: a selected pixel is the style's colour blended once over the terrain's, to within
/// 2/255 per channel (the source colour and the blend result are each rounded to 8 bits).
constexpr double kHighlightTolerance = 2.0;
/// Show volumes: a pixel met by k faces is the colour blended k times; each blend rounds to 8
/// bits (the CPU rounds too, but may round the other way): 1/255 per blend, plus 1.
double volumeTolerance(int faces) { return 1.0 + faces; }

/// Highlight styles checked (straight alpha colour, opacity): add more here.
const overlay::SelectionStyle kStyles[] = {
    {glm::vec4(1.0F, 0.2F, 0.1F, 1.0F), 0.45F},
    {glm::vec4(0.1F, 0.4F, 1.0F, 0.8F), 0.7F},
};
/// "Show volumes" colour (straight alpha).
const glm::vec4 kVolumeColour{0.2F, 0.9F, 0.3F, 0.35F};

using Camera = LassoCamera;

Camera cameraAt(const glm::dvec3& eye, const glm::dvec3& target) { return lassoCameraAt(eye, target); }

overlay::OverlayView overlayView(const Camera& c) {
  return {c.viewProj, c.eye, 1.0, kFov, static_cast<double>(kWidth) / kHeight};
}

std::vector<glm::dvec2> randomPolygon(std::mt19937& rng) { return randomLassoPolygon(rng); }

overlay::SelectionStep stepFrom(overlay::SelectionOp op, const Camera& c, std::vector<glm::dvec2> points,
                                double distance = std::numeric_limits<double>::infinity()) {
  return {op, lassoFrom(c, std::move(points), distance)};
}

overlay::SelectionStep invertStep() {
  overlay::SelectionStep s;
  s.op = overlay::SelectionOp::Invert;
  return s;
}

glm::dvec4 pixelAt(const std::vector<std::uint8_t>& rgba, std::size_t i) {
  return {rgba[4 * i], rgba[4 * i + 1], rgba[4 * i + 2], rgba[4 * i + 3]};
}

bool samePixel(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b, std::size_t i) {
  return std::equal(a.begin() + static_cast<std::ptrdiff_t>(4 * i), a.begin() + static_cast<std::ptrdiff_t>(4 * i + 4),
                    b.begin() + static_cast<std::ptrdiff_t>(4 * i));
}

/// `colour` (straight alpha) blended `times` times over `dst` (0–255 per channel) with
/// premultiplied over (src · 1 + dst · (1 − a)), rounded to 8 bits after every blend.
glm::dvec4 blendedOver(glm::dvec4 dst, const glm::dvec4& colour, int times) {
  const double a = colour.w;
  for (int t = 0; t < times; ++t) {
    for (int c = 0; c < 3; ++c) dst[c] = std::round(255.0 * colour[c] * a + dst[c] * (1.0 - a));
    dst.w = std::round(255.0 * a + dst.w * (1.0 - a));
  }
  return dst;
}

double maxChannelDifference(const glm::dvec4& a, const glm::dvec4& b) {
  const glm::dvec4 d = glm::abs(a - b);
  return std::max(std::max(d.x, d.y), std::max(d.z, d.w));
}

void saveImage(const std::string& name, const std::vector<std::uint8_t>& pixels, int channels) {
  const std::filesystem::path dir(STENCIL_GIS_TEST_OUTPUT_DIR);
  std::filesystem::create_directories(dir);
  const Result<bool> written = gfx::writeImage8((dir / (name + ".png")).string(), kWidth, kHeight, channels, pixels);
  EXPECT_TRUE(written.ok()) << name;
}

/// One drawn frame: the terrain seen from a camera, its colour and depth before any selection.
struct Frame {
  Camera view;
  std::unique_ptr<gfx::RenderTarget> target;
  std::vector<std::uint8_t> color;
  std::vector<float> depth;
  [[nodiscard]] overlay::DepthImage image() const { return {kWidth, kHeight, depth, view.viewProj}; }
  [[nodiscard]] bool geometry(std::size_t i) const { return depth[i] > 0.0F; }
};

/// The tally of one comparison; `wrong` pixels fail the test.
struct Tally {
  /// Compared pixels: expected to change or not; `background` of them had nothing drawn.
  std::size_t checked = 0, changed = 0, unchanged = 0, background = 0;
  std::size_t nearBoundary = 0, wrong = 0;  ///< not compared; compared and wrong
  std::size_t outsideVolumes = 0;           ///< selected pixels whose point lies in no volume (Invert)
  double maxError = 0.0;                    ///< of the changed pixels, 8-bit units
  double minContrast = 255.0;               ///< smallest change expected at a changed pixel, 8-bit units
  int maxFaces = 0;                         ///< show volumes: most faces met by one checked pixel
  void add(const Tally& o) {
    checked += o.checked, changed += o.changed, unchanged += o.unchanged, background += o.background;
    nearBoundary += o.nearBoundary, wrong += o.wrong, outsideVolumes += o.outsideVolumes;
    maxError = std::max(maxError, o.maxError), minContrast = std::min(minContrast, o.minContrast);
    maxFaces = std::max(maxFaces, o.maxFaces);
  }
};

/// Reports the first wrong pixels of a comparison, and writes a map of them (white: wrong, grey:
/// near a boundary, not checked) next to the images.
class WrongPixels {
 public:
  explicit WrongPixels(std::string label) : label_(std::move(label)), map_(kPixels, 0) {}
  void nearBoundary(std::size_t i) { map_[i] = 96; }
  void wrong(std::size_t i, const std::string& what) {
    map_[i] = 255;
    if (reported_++ < 5) {
      ADD_FAILURE() << label_ << ": pixel (" << i % kWidth << ", " << i / kWidth << ") " << what;
    }
  }
  ~WrongPixels() {
    if (reported_ > 0) saveImage(label_ + "_wrong", map_, 1);
  }
  WrongPixels(const WrongPixels&) = delete;
  WrongPixels& operator=(const WrongPixels&) = delete;

 private:
  std::string label_;
  std::vector<std::uint8_t> map_;
  int reported_ = 0;
};

std::string describe(const glm::dvec4& gpu, const glm::dvec4& expected) {
  char text[160];
  std::snprintf(text, sizeof text, "GPU (%g, %g, %g, %g), expected (%g, %g, %g, %g)", gpu.x, gpu.y, gpu.z, gpu.w,
                expected.x, expected.y, expected.z, expected.w);
  return text;
}

// ---- Show volumes on the CPU -------------------------------------------------------------------

/// Pixels whose centre lies within this many pixels of a projected face edge may go either way:
/// the rasteriser snaps vertices to 1/256 pixel, and the vertices are float.
constexpr double kEdgeMargin = 0.05;
/// … and so may pixels where a face's depth is within this fraction of the terrain's (float
/// vertices relative to the eye, float matrix: about 1e-6 of the depth).
constexpr double kDepthMargin = 1e-5;

/// Per pixel, how many faces of the volumes "show volumes" blends there seen from `frame`'s
/// camera: the faces that the pixel's view ray meets beyond half the near distance (where the
/// renderer clips; nearer than the near plane depth clamp holds the depth at 1), at a depth
/// greater than the terrain's (reversed-Z). A rasterisation in double: every triangle
/// (homogeneous, w = 0 at infinity) is taken to the view's clip space and clipped at
/// w = near / 2; each piece, as homogeneous pixel points P = ((x + w)·W/2, (w − y)·H/2, w), covers
/// the pixel centre p when p lies on the inner side of its three edge lines Pⱼ × Pₖ, and its depth
/// there is Σ λᵢ zᵢ with λ the solution of Σ λᵢ Pᵢ = (p, 1). Faces seen exactly edge on (their
/// plane through the eye: zero projected area) are skipped, as the renderer does. `uncertain`
/// marks pixels within kEdgeMargin of a piece's edge or within kDepthMargin of the terrain.
std::vector<int> visibleFaceCounts(const std::vector<overlay::LassoVolume>& volumes, const Frame& frame,
                                   std::vector<std::uint8_t>& uncertain) {
  std::vector<int> counts(kPixels, 0);
  uncertain.assign(kPixels, 0);
  const double wMin = 0.5;  // half the view's near distance (1 m)
  const auto toPixels = [](const glm::dvec4& c) {
    return glm::dvec3((c.x + c.w) * 0.5 * kWidth, (c.w - c.y) * 0.5 * kHeight, c.w);
  };
  for (const overlay::LassoVolume& volume : volumes) {
    for (const auto& t : volume.triangles) {
      std::array<glm::dvec4, 3> c;
      std::array<double, 3> g;
      for (std::size_t k = 0; k < 3; ++k) {
        c[k] = frame.view.viewProj * t[k];
        g[k] = c[k].w - wMin * t[k].w;
      }
      const glm::dvec3 a = toPixels(c[0]), b = toPixels(c[1]), e = toPixels(c[2]);
      if (std::abs(glm::dot(a, glm::cross(b, e))) <= 1e-9 * glm::length(a) * glm::length(b) * glm::length(e)) {
        continue;  // edge on
      }
      std::vector<glm::dvec4> poly;
      for (std::size_t k = 0; k < 3; ++k) {
        const std::size_t n = (k + 1) % 3;
        if (g[k] >= 0.0) poly.push_back(c[k]);
        if ((g[k] >= 0.0) != (g[n] >= 0.0)) poly.push_back(c[k] + (g[k] / (g[k] - g[n])) * (c[n] - c[k]));
      }
      for (std::size_t k = 1; k + 1 < poly.size(); ++k) {
        const std::array<glm::dvec4, 3> v{poly[0], poly[k], poly[k + 1]};
        const std::array<glm::dvec3, 3> q{toPixels(v[0]), toPixels(v[1]), toPixels(v[2])};
        const double area = glm::dot(q[0], glm::cross(q[1], q[2]));
        if (area == 0.0) continue;
        // Edge lines opposite each vertex, and their lengths for distances in pixels.
        std::array<glm::dvec3, 3> line;
        std::array<double, 3> norm;
        for (std::size_t j = 0; j < 3; ++j) {
          line[j] = glm::cross(q[(j + 1) % 3], q[(j + 2) % 3]);
          norm[j] = std::hypot(line[j].x, line[j].y);
        }
        for (std::size_t i = 0; i < kPixels; ++i) {
          const glm::dvec3 p(static_cast<double>(i % kWidth) + 0.5, static_cast<double>(i / kWidth) + 0.5, 1.0);
          double depth = 0.0, nearest = std::numeric_limits<double>::infinity();
          for (std::size_t j = 0; j < 3; ++j) {
            const double side = glm::dot(line[j], p);  // λⱼ · area
            nearest = std::min(nearest, (area > 0.0 ? side : -side) / norm[j]);
            depth += side / area * v[j].z;
          }
          if (std::abs(nearest) < kEdgeMargin) uncertain[i] = 1;
          if (nearest < 0.0) continue;
          depth = std::clamp(depth, 0.0, 1.0);
          const double terrain = frame.depth[i];
          if (std::abs(depth - terrain) <= kDepthMargin * std::max(depth, terrain)) uncertain[i] = 1;
          if (depth > terrain) ++counts[i];
        }
      }
    }
  }
  return counts;
}

// ---- The fixture -------------------------------------------------------------------------------

class SelectionImageGlTest : public SelectionSceneTest {
 protected:
  /// Draws the terrain (colour, depth, stencil 0) and reads colour and depth back.
  Frame drawTerrain(const Camera& view) {
    Frame f{view, std::make_unique<gfx::RenderTarget>(kWidth, kHeight), {}, {}};
    gfx::enableReversedZ();
    gfx::beginRenderPass(cache_, *f.target, {kBackground, gfx::kReversedZFar, 0});
    const terrain::LodSelection lod =
        terrain::selectLod(*tree_, terrain::LodView{view.eye, view.viewProj, kHeight, kFov});
    engine_->draw(cache_, view.viewProj, view.eye, lod, 1.0);
    f.color = gfx::readColorRgba8(*f.target);
    f.depth = gfx::readDepth(*f.target);
    return f;
  }

  /// Selects `steps` on `frame`, highlights with `style` and compares the colour with the twin:
  /// selected pixels ≈ the blend, all others exactly as before. Checks the stencil is 0 after,
  /// and that a second highlight changes nothing.
  Tally highlightAndCompare(Frame& frame, const std::vector<overlay::SelectionStep>& steps,
                            const overlay::SelectionStyle& style, overlay::SelectionScheme scheme,
                            const std::string& label) {
    (void)selection_->setSteps(steps);
    overlay::SelectionSettings settings;
    settings.scheme = scheme;
    selection_->select(cache_, overlayView(frame.view), settings);
    selection_->highlight(cache_, style, settings);
    const std::vector<std::uint8_t> after = gfx::readColorRgba8(*frame.target);
    const std::vector<std::uint8_t> stencil = gfx::readStencil(*frame.target);
    const std::size_t leftover = kPixels - static_cast<std::size_t>(std::count(stencil.begin(), stencil.end(), 0));
    EXPECT_EQ(leftover, 0u) << label << ": stencil not 0 after highlight";
    selection_->highlight(cache_, style, settings);
    EXPECT_TRUE(gfx::readColorRgba8(*frame.target) == after) << label << ": a second highlight changed the colour";

    const glm::dvec4 colour(style.color.x, style.color.y, style.color.z, style.color.w * style.opacity);
    const overlay::DepthImage image = frame.image();
    const std::vector<std::uint8_t> expected = overlay::selectionMask(image, steps);
    saveImage(label + "_before", frame.color, 4);
    saveImage(label + "_after", after, 4);
    WrongPixels wrong(label);
    Tally r;
    for (std::size_t i = 0; i < kPixels; ++i) {
      const glm::dvec4 before = pixelAt(frame.color, i), gpu = pixelAt(after, i);
      if (!frame.geometry(i)) {
        ++r.checked, ++r.unchanged, ++r.background;
        if (!samePixel(frame.color, after, i))
          ++r.wrong, wrong.wrong(i, "background changed: " + describe(gpu, before));
        continue;
      }
      const glm::dvec4 blended = blendedOver(before, colour, 1);
      if (nearBoundary(frame, steps, i, expected[i] != 0)) {
        // Either state is right here, but nothing else.
        ++r.nearBoundary;
        wrong.nearBoundary(i);
        if (!samePixel(frame.color, after, i) && maxChannelDifference(gpu, blended) > kHighlightTolerance) {
          ++r.wrong, wrong.wrong(i, "near a boundary, neither unchanged nor highlighted: " + describe(gpu, blended));
        }
        continue;
      }
      ++r.checked;
      if (expected[i] == 0) {
        ++r.unchanged;
        if (!samePixel(frame.color, after, i)) ++r.wrong, wrong.wrong(i, "not selected: " + describe(gpu, before));
        continue;
      }
      ++r.changed;
      const double error = maxChannelDifference(gpu, blended);
      r.maxError = std::max(r.maxError, error);
      r.minContrast = std::min(r.minContrast, maxChannelDifference(blended, before));
      if (error > kHighlightTolerance) ++r.wrong, wrong.wrong(i, "selected: " + describe(gpu, blended));
      const glm::dvec3 p = *overlay::unprojectPixel(image, static_cast<int>(i % kWidth), static_cast<int>(i / kWidth));
      if (std::none_of(steps.begin(), steps.end(), [&](const overlay::SelectionStep& s) {
            return s.op != overlay::SelectionOp::Invert && overlay::insideLasso(s.lasso, p);
          })) {
        ++r.outsideVolumes;
      }
    }
    return r;
  }

  /// The criterion of selection_gltest: the pixel's terrain point moved by 2·10⁻⁴ of its distance
  /// from the eye (+1 cm) along an axis changes the twin's answer (float vertices, depth
  /// precision). Background pixels have no point and are handled apart.
  static bool nearBoundary(const Frame& frame, const std::vector<overlay::SelectionStep>& steps, std::size_t i,
                           bool selected) {
    const std::optional<glm::dvec3> p =
        overlay::unprojectPixel(frame.image(), static_cast<int>(i % kWidth), static_cast<int>(i / kWidth));
    if (!p) return true;
    const double d = 2e-4 * glm::length(*p - frame.view.eye) + 0.01;
    for (const glm::dvec3& o : {glm::dvec3(d, 0, 0), glm::dvec3(-d, 0, 0), glm::dvec3(0, d, 0), glm::dvec3(0, -d, 0),
                                glm::dvec3(0, 0, d), glm::dvec3(0, 0, -d)}) {
      if (overlay::selectedAt(steps, *p + o) != selected) return true;
    }
    return false;
  }

  /// "Show volumes" of `steps` on `frame` seen from its camera, against visibleFaceCounts: a
  /// pixel met by k faces is the colour blended k times over the terrain (k = 0: bit-identical).
  /// Not checked: pixels within kEdgeMargin of a projected face edge, or where a face's depth is
  /// within kDepthMargin of the terrain's (where it crosses the terrain). `lassoView`: the
  /// lassos were all drawn with this camera, so the changed pixels must be exactly those inside
  /// some lasso polygon (the light caps; the walls are seen edge on).
  Tally showVolumesAndCompare(Frame& frame, const std::vector<overlay::SelectionStep>& steps, bool lassoView,
                              const std::string& label) {
    (void)selection_->setSteps(steps);
    selection_->drawVolumes(cache_, overlayView(frame.view), kVolumeColour);
    const std::vector<std::uint8_t> after = gfx::readColorRgba8(*frame.target);
    const std::vector<std::uint8_t> stencil = gfx::readStencil(*frame.target);
    EXPECT_EQ(std::count(stencil.begin(), stencil.end(), 0), static_cast<std::ptrdiff_t>(kPixels))
        << label << ": show volumes wrote the stencil";
    saveImage(label + "_before", frame.color, 4);
    saveImage(label + "_after", after, 4);

    std::vector<overlay::LassoVolume> volumes;
    Diagnostics diagnostics;
    for (const overlay::SelectionStep& s : steps) {
      if (s.op != overlay::SelectionOp::Invert)
        volumes.push_back(overlay::buildLassoVolume(s.lasso, label, diagnostics));
    }
    EXPECT_TRUE(diagnostics.empty()) << label;
    std::vector<std::uint8_t> uncertain;
    const std::vector<int> faces = visibleFaceCounts(volumes, frame, uncertain);
    const glm::dmat4 inverse = glm::inverse(frame.view.viewProj);
    WrongPixels wrong(label);
    Tally r;
    for (std::size_t i = 0; i < kPixels; ++i) {
      const int x = static_cast<int>(i % kWidth), y = static_cast<int>(i / kWidth);
      const bool boundary = uncertain[i] != 0;
      if (boundary) {
        ++r.nearBoundary;
        wrong.nearBoundary(i);
        continue;
      }
      ++r.checked;
      if (!frame.geometry(i)) ++r.background;
      const glm::dvec4 before = pixelAt(frame.color, i), gpu = pixelAt(after, i);
      if (lassoView) {
        // The pixel centre's ray just beyond the near plane, in the lassos' own camera.
        const glm::dvec4 h =
            inverse * glm::dvec4(2.0 * (x + 0.5) / kWidth - 1.0, 1.0 - 2.0 * (y + 0.5) / kHeight, 0.99, 1.0);
        const glm::dvec3 point = glm::dvec3(h) / h.w;
        const bool insideSome = std::any_of(steps.begin(), steps.end(), [&](const overlay::SelectionStep& s) {
          return s.op != overlay::SelectionOp::Invert && overlay::insideLasso(s.lasso, point);
        });
        if (insideSome != (faces[i] > 0)) {
          ++r.wrong, wrong.wrong(i, "CPU faces " + std::to_string(faces[i]) + " but inside a lasso " +
                                        std::to_string(insideSome));
        }
      }
      if (faces[i] == 0) {
        ++r.unchanged;
        if (!samePixel(frame.color, after, i)) ++r.wrong, wrong.wrong(i, "no face: " + describe(gpu, before));
        continue;
      }
      ++r.changed;
      r.maxFaces = std::max(r.maxFaces, faces[i]);
      const glm::dvec4 blended = blendedOver(before, glm::dvec4(kVolumeColour), faces[i]);
      const double error = maxChannelDifference(gpu, blended);
      r.maxError = std::max(r.maxError, error);
      r.minContrast = std::min(r.minContrast, maxChannelDifference(blended, before));
      if (error > volumeTolerance(faces[i])) {
        ++r.wrong, wrong.wrong(i, std::to_string(faces[i]) + " faces: " + describe(gpu, blended));
      }
    }
    return r;
  }
};

void print(const char* what, const Tally& t) {
  std::printf(
      "%s: %zu pixels checked (%zu changed, %zu unchanged, %zu of them background), %zu near boundaries (not "
      "checked), %zu wrong; max channel error %.0f/255, smallest expected change %.0f/255",
      what, t.checked, t.changed, t.unchanged, t.background, t.nearBoundary, t.wrong, t.maxError, t.minContrast);
  if (t.outsideVolumes > 0) std::printf("; %zu selected outside every volume", t.outsideVolumes);
  if (t.maxFaces > 0) std::printf("; up to %d faces on a pixel", t.maxFaces);
  std::printf("\n");
}

/// Enough pixels of each kind for the comparison to mean something.
void expectMeaningful(const Tally& t, std::size_t changed, std::size_t unchanged) {
  EXPECT_GE(t.changed, changed);
  EXPECT_GE(t.unchanged, unchanged);
  // A changed pixel left as it was cannot pass: the expected change is well above any tolerance
  // for one blend (kHighlightTolerance, volumeTolerance(1)).
  EXPECT_GE(t.minContrast, 3.0 * std::max(kHighlightTolerance, volumeTolerance(1)));
  EXPECT_LE(t.nearBoundary, t.checked / 10);
}

const char* schemeName(overlay::SelectionScheme s) { return s == overlay::SelectionScheme::Runs ? "runs" : "report"; }

TEST_F(SelectionImageGlTest, HighlightBlendsTheStyleOverSelectedPixelsOnly) {
  std::mt19937 rng(5);
  Tally total;
  for (int trial = 0; trial < 3; ++trial) {
    const Camera view = randomCamera(rng);
    // Single + Or from the view's camera, Subtract from another one.
    const std::vector<overlay::SelectionStep> steps = {
        stepFrom(overlay::SelectionOp::Single, view, randomPolygon(rng)),
        stepFrom(overlay::SelectionOp::Or, view, randomPolygon(rng)),
        stepFrom(overlay::SelectionOp::Subtract, randomCamera(rng), randomPolygon(rng))};
    for (std::size_t style = 0; style < std::size(kStyles); ++style) {
      for (const auto scheme : {overlay::SelectionScheme::Runs, overlay::SelectionScheme::Report}) {
        Frame frame = drawTerrain(view);
        const Tally t = highlightAndCompare(
            frame, steps, kStyles[style], scheme,
            "highlight_" + std::to_string(trial) + "_style" + std::to_string(style) + "_" + schemeName(scheme));
        total.add(t);
      }
    }
  }
  print("highlight", total);
  EXPECT_EQ(total.wrong, 0u);
  expectMeaningful(total, 20000, 20000);
}

TEST_F(SelectionImageGlTest, InvertSelectsGeometryOutsideTheVolumesNeverBackground) {
  std::mt19937 rng(17);
  Tally total;
  for (int trial = 0; trial < 3; ++trial) {
    const Camera view = randomCamera(rng);
    const Camera other = randomCamera(rng);
    const std::vector<overlay::SelectionStep> chains[] = {
        // Invert at the end.
        {stepFrom(overlay::SelectionOp::Single, view, randomPolygon(rng)),
         stepFrom(overlay::SelectionOp::Or, other, randomPolygon(rng)), invertStep()},
        // Invert in the middle, then more operators.
        {stepFrom(overlay::SelectionOp::Single, view, randomPolygon(rng)), invertStep(),
         stepFrom(overlay::SelectionOp::Or, view, randomPolygon(rng)),
         stepFrom(overlay::SelectionOp::Subtract, other, randomPolygon(rng), 800.0)},
        // Invert first (everything drawn), Xor, Invert again.
        {invertStep(), stepFrom(overlay::SelectionOp::Xor, view, randomPolygon(rng)), invertStep()},
    };
    for (std::size_t c = 0; c < std::size(chains); ++c) {
      for (const auto scheme : {overlay::SelectionScheme::Runs, overlay::SelectionScheme::Report}) {
        Frame frame = drawTerrain(view);
        const Tally t = highlightAndCompare(
            frame, chains[c], kStyles[static_cast<std::size_t>(trial) % std::size(kStyles)], scheme,
            "invert_" + std::to_string(trial) + "_chain" + std::to_string(c) + "_" + schemeName(scheme));
        total.add(t);
      }
    }
  }
  print("invert", total);
  EXPECT_EQ(total.wrong, 0u);
  expectMeaningful(total, 20000, 20000);
  EXPECT_GE(total.outsideVolumes, 20000u);  // Invert selected geometry that no volume holds
}

TEST_F(SelectionImageGlTest, ShowVolumesColoursExactlyThePixelsWhoseRayMeetsAVisibleFace) {
  std::mt19937 rng(29);
  Tally own, others;
  for (int trial = 0; trial < 3; ++trial) {
    const Camera drawnFrom = randomCamera(rng);
    // Three lassos from one camera (ops do not matter here), one ending at a distance that may
    // lie in front of the terrain (its dark cap then shows).
    std::vector<overlay::SelectionStep> steps = {
        stepFrom(overlay::SelectionOp::Single, drawnFrom, randomPolygon(rng)),
        stepFrom(overlay::SelectionOp::Or, drawnFrom, randomPolygon(rng), 400.0 + 1500.0 * (trial + 1) / 3.0),
        stepFrom(overlay::SelectionOp::Xor, drawnFrom, randomPolygon(rng))};
    Frame a = drawTerrain(drawnFrom);
    own.add(showVolumesAndCompare(a, steps, true, "volumes_" + std::to_string(trial) + "_own"));
    // The same volumes, and one more lasso drawn from a third camera, seen from a camera looking
    // at the first lasso's middle (walls and caps at an angle), and from inside the first volume
    // (faces behind the eye, clipped).
    steps.push_back(stepFrom(overlay::SelectionOp::Subtract, randomCamera(rng), randomPolygon(rng), 1500.0));
    glm::dvec2 middle(0.0);
    for (const glm::dvec2& q : steps[0].lasso.points) middle += q;
    middle /= static_cast<double>(steps[0].lasso.points.size());
    const glm::dmat4 inverse = glm::inverse(drawnFrom.viewProj);
    const auto along = [&](double depth) {
      const glm::dvec4 h =
          inverse * glm::dvec4(2.0 * middle.x / kWidth - 1.0, 1.0 - 2.0 * middle.y / kHeight, depth, 1.0);
      return glm::dvec3(h) / h.w;
    };
    const std::optional<glm::dvec3> seen =
        overlay::unprojectPixel(a.image(), static_cast<int>(middle.x), static_cast<int>(middle.y));
    Frame b = drawTerrain(randomCamera(rng, glm::dvec2(seen.value_or(along(0.002)))));
    others.add(showVolumesAndCompare(b, steps, false, "volumes_" + std::to_string(trial) + "_other"));
    Frame c = drawTerrain(cameraAt(along(0.02), glm::dvec3(lo_ + (hi_ - lo_) * glm::dvec2(0.3 + 0.2 * trial), 0.0)));
    others.add(showVolumesAndCompare(c, steps, false, "volumes_" + std::to_string(trial) + "_inside"));
  }
  print("show volumes, own camera", own);
  print("show volumes, other cameras", others);
  EXPECT_EQ(own.wrong, 0u);
  EXPECT_EQ(others.wrong, 0u);
  expectMeaningful(own, 10000, 10000);
  expectMeaningful(others, 10000, 10000);
}

}  // namespace
}  // namespace gis::test
