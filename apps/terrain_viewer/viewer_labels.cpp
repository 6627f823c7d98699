// Labels from an attribute (per layer): anchors on the ground computed once (app/labels.hpp),
// projected every frame, hidden ones left out, and placed on screen without overlap, clear of the
// panel, the HUD and the status bar. Both frames anchor the scene layer's features as read; on
// the globe each is anchored in a plane about its middle and kept in lon/lat.
#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "gfx/gl.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#include "gfx/render_target.hpp"
#include "globe/ellipsoid.hpp"
#include "viewer.hpp"

namespace gis::viewer {

namespace {

/// A plane about (lon0, lat0): degrees to metres, east and north (equirectangular), and back.
struct LocalPlane {
  double lon0 = 0.0, lat0 = 0.0, east = kMetresPerDegree;
  [[nodiscard]] glm::dvec2 forward(const glm::dvec2& ll) const {
    return {(ll.x - lon0) * east, (ll.y - lat0) * kMetresPerDegree};
  }
  [[nodiscard]] glm::dvec2 back(const glm::dvec2& xy) const {
    return {lon0 + xy.x / east, lat0 + xy.y / kMetresPerDegree};
  }
};

}  // namespace

void Viewer::setLabels(std::size_t sceneLayer, const std::string& attribute) {
  labelSets_.erase(sceneLayer);
  labelPlacer_.forget();
  if (attribute.empty()) return;
  const std::vector<geo::Feature>* features = featuresOf(sceneLayer);
  if (features == nullptr) return;
  LabelSet set;
  set.attribute = attribute;
  if (!globe_) {
    set.labels = app::layerLabels(*features, attribute);
  } else {
    // Longitude and latitude: each feature anchored in a plane about its middle (its longitudes
    // unwrapped about its first point, across ±180°), the anchor taken back to lon/lat.
    for (std::size_t f = 0; f < features->size(); ++f) {
      const geo::Feature& feature = (*features)[f];
      std::optional<std::string> text = app::labelText(feature, attribute);
      if (!text) continue;
      std::optional<double> reference;
      glm::dvec2 sum(0.0);
      std::size_t n = 0;
      const auto unwrap = [&](std::vector<glm::dvec2> points) {
        for (glm::dvec2& p : points) {
          if (!reference) reference = p.x;
          p.x += 360.0 * std::round((*reference - p.x) / 360.0);
          sum += p;
          ++n;
        }
        return points;
      };
      geo::Feature flat;
      for (const geo::Polygon& polygon : feature.polygons) {
        geo::Polygon unwrapped{unwrap(polygon.outer), {}};
        for (const geo::Ring& hole : polygon.holes) unwrapped.holes.push_back(unwrap(hole));
        flat.polygons.push_back(std::move(unwrapped));
      }
      for (const geo::LineString& line : feature.lines) flat.lines.push_back(unwrap(line));
      if (n == 0) continue;
      LocalPlane plane;
      plane.lon0 = sum.x / static_cast<double>(n);
      plane.lat0 = std::clamp(sum.y / static_cast<double>(n), -89.0, 89.0);
      plane.east = kMetresPerDegree * std::cos(glm::radians(plane.lat0));
      const auto flatten = [&plane](std::vector<glm::dvec2>& points) {
        for (glm::dvec2& p : points) p = plane.forward(p);
      };
      for (geo::Polygon& polygon : flat.polygons) {
        flatten(polygon.outer);
        for (geo::Ring& hole : polygon.holes) flatten(hole);
      }
      for (geo::LineString& line : flat.lines) flatten(line);
      std::optional<app::LabelAnchor> anchor = app::featureLabelAnchor(flat);
      if (!anchor) continue;
      anchor->point = plane.back(anchor->point);
      set.labels.push_back({f, feature.fid, std::move(*text), *anchor});
    }
  }
  labelSets_[sceneLayer] = std::move(set);  // the anchors' heights are looked up as drawn
  showLabels_ = true;
}

void Viewer::rememberWindow(const std::string& name) {
  const ImVec2 p = ImGui::GetWindowPos(), size = ImGui::GetWindowSize();
  windowRects_[name] = glm::vec4(p.x, p.y, p.x + size.x, p.y + size.y);
}

void Viewer::drawLabels() {
  if (labelSets_.empty() || !target_) return;
  const double exaggeration = this->exaggeration();
  const glm::dmat4 viewProj = screenViewProj();
  const int w = target_->width(), h = target_->height();
  const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
  const std::vector<float>& depth = frameDepth();
  std::vector<app::LabelCandidate> candidates;
  std::vector<const std::string*> texts;
  for (auto& [sceneLayer, set] : labelSets_) {
    if (!layerShown(sceneLayer).value_or(false)) continue;
    if (set.exaggeration != exaggeration) {
      // The anchors' heights as drawn, once per exaggeration.
      set.heights.resize(set.labels.size());
      for (std::size_t k = 0; k < set.labels.size(); ++k) {
        const glm::dvec2& p = set.labels[k].anchor.point;
        set.heights[k] = scene_->heightAt(p);
      }
      set.exaggeration = exaggeration;
    }
    for (std::size_t k = 0; k < set.labels.size(); ++k) {
      const app::FeatureLabel& label = set.labels[k];
      if (!std::isfinite(set.heights[k])) continue;
      const glm::dvec3 at = scene_->worldPoint(label.anchor.point, set.heights[k]);
      const glm::dvec4 clip = viewProj * glm::dvec4(at, 1.0);
      if (!(clip.w > 0.0)) continue;
      const glm::dvec3 ndc = glm::dvec3(clip) / clip.w;
      const double px = (ndc.x * 0.5 + 0.5) * w, py = (0.5 - ndc.y * 0.5) * h;
      if (px < 0.0 || py < 0.0 || px >= w || py >= h) continue;
      // Hidden behind the terrain: not labelled.
      const float drawn =
          depth[static_cast<std::size_t>(py) * static_cast<std::size_t>(w) + static_cast<std::size_t>(px)];
      if (ndc.z < static_cast<double>(drawn) / 1.005) continue;
      app::LabelCandidate candidate;
      candidate.anchor = glm::vec2(static_cast<float>(px) / scale.x, static_cast<float>(py) / scale.y);
      const ImVec2 size = ImGui::CalcTextSize(label.text.c_str());
      candidate.size = glm::vec2(size.x + 6.0F, size.y + 2.0F);
      // Larger features first, and nearer ones (their size on screen).
      candidate.priority = std::sqrt(std::max(label.anchor.partSize, 1.0)) / clip.w;
      candidate.id = static_cast<std::int64_t>((sceneLayer << 40U) | label.feature);
      candidates.push_back(candidate);
      texts.push_back(&label.text);
    }
  }
  app::LabelLayout layout;
  const ImGuiViewport* viewport = ImGui::GetMainViewport();
  layout.screen = {glm::vec2(viewport->WorkPos.x, viewport->WorkPos.y),
                   glm::vec2(viewport->WorkPos.x + viewport->WorkSize.x,
                             viewport->WorkPos.y + viewport->WorkSize.y - ImGui::GetFrameHeight())};
  // The panel and the other windows as last drawn.
  for (const auto& [name, r] : windowRects_) layout.blocked.push_back({glm::vec2(r.x, r.y), glm::vec2(r.z, r.w)});
  layout.stabilityBonus = 1e30;
  const std::vector<app::PlacedLabel>& placed = labelPlacer_.place(candidates, layout);
  labelsPlaced_ = placed.size();
  ImDrawList* draw = ImGui::GetBackgroundDrawList();
  for (const app::PlacedLabel& p : placed) {
    const std::string& text = *texts[p.candidate];
    draw->AddRectFilled(ImVec2(p.rect.min.x, p.rect.min.y), ImVec2(p.rect.max.x, p.rect.max.y), IM_COL32(0, 0, 0, 140),
                        3.0F);
    draw->AddText(ImVec2(p.rect.min.x + 3.0F, p.rect.min.y + 1.0F), IM_COL32(255, 255, 255, 255), text.c_str());
  }
}

}  // namespace gis::viewer
