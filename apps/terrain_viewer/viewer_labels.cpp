// Labels from an attribute (per layer): anchors on the ground computed once (app/labels.hpp),
// projected every frame, hidden ones left out, and placed on screen without overlap, clear of the
// panel, the HUD and the status bar.
#include <algorithm>
#include <cmath>
#include <string>

#include "gfx/gl.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <glm/geometric.hpp>

#include "gfx/render_target.hpp"
#include "viewer.hpp"

namespace gis::viewer {

void Viewer::setLabels(std::size_t sceneLayer, const std::string& attribute) {
  labelSets_.erase(sceneLayer);
  labelPlacer_.forget();
  if (attribute.empty()) return;
  const std::optional<std::size_t> fill = fillLayerOf(sceneLayer);
  if (!fill) return;
  LabelSet set;
  set.attribute = attribute;
  set.labels = app::layerLabels(renderer_->overlayLayers()[*fill].features(), attribute);
  labelSets_[sceneLayer] = std::move(set);
  showLabels_ = true;
}

void Viewer::rememberWindow(const std::string& name) {
  const ImVec2 p = ImGui::GetWindowPos(), size = ImGui::GetWindowSize();
  windowRects_[name] = glm::vec4(p.x, p.y, p.x + size.x, p.y + size.y);
}

void Viewer::drawLabels() {
  if (labelSets_.empty() || !target_) return;
  const double exaggeration = scene_->bounds->exaggeration();
  const scene::Camera c = camera();
  const glm::dmat4 viewProj = c.projection(aspect()) * c.view();
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
        set.heights[k] = scene_->bounds->fullResolutionHeightAt(set.labels[k].anchor.point);
      }
      set.exaggeration = exaggeration;
    }
    for (std::size_t k = 0; k < set.labels.size(); ++k) {
      const app::FeatureLabel& label = set.labels[k];
      if (!std::isfinite(set.heights[k])) continue;
      const glm::dvec4 clip = viewProj * glm::dvec4(label.anchor.point, set.heights[k], 1.0);
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
