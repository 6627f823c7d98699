// The measure tool (M): clicks put points on the ground; the path between them is measured along
// the ellipsoid (geodesic) and along the terrain's surface, and, closed into a ring, its area. In
// a projected scene the points are frame x/y; on the globe they are lon/lat, and the segments are
// drawn along their geodesics.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "gfx/gl.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>

#include "globe/ellipsoid.hpp"
#include "viewer.hpp"

namespace gis::viewer {

void Viewer::addMeasurePoint(const glm::dvec2& frameXY) {
  measurePoints_.push_back(frameXY);
  remeasure();
}

void Viewer::clearMeasure() {
  measurePoints_.clear();
  measurement_.reset();
}

void Viewer::remeasure() {
  measurement_.reset();
  if (measurePoints_.size() < 2) return;
  // Map points: frame x/y, or on the globe lon/lat (its segments geodesics on WGS 84).
  Result<scene::Measurement> m = scene_->measure(measurePoints_, measureClosed_ && measurePoints_.size() >= 3);
  message(m.diagnostics);
  if (m) measurement_ = std::move(*m);
}

bool Viewer::measureAtPixels(const std::vector<glm::dvec2>& pixels, bool closed) {
  clearMeasure();
  measureClosed_ = closed;
  for (const glm::dvec2& p : pixels) {
    const std::optional<glm::dvec2> ground = measurePointAt(p);
    if (!ground) {
      clearMeasure();
      return false;
    }
    measurePoints_.push_back(*ground);
  }
  remeasure();
  return true;
}

std::optional<glm::dvec2> Viewer::measurePointAt(const glm::dvec2& pixel) const {
  const std::optional<glm::dvec3> p = pointAt(pixel);
  return p ? std::optional<glm::dvec2>(scene_->mapPoint(*p)) : std::nullopt;
}

glm::dvec3 Viewer::measurePointPosition(const glm::dvec2& p) const {
  return scene_->worldPoint(p, scene_->heightAt(p));
}

void Viewer::drawMeasure() {
  if (measurePoints_.empty()) return;
  const ImU32 colour = IM_COL32(255, 235, 60, 255);
  const bool ring = measureClosed_ && measurePoints_.size() >= 3;
  if (globe_) {
    // Along the geodesics, in pieces of a few pixels where the view looks (at most 4,096 a segment).
    const double step = std::max(4.0 * metresPerPixelAtCentre().value_or(1000.0), 0.5);
    std::vector<glm::dvec3> path;
    for (const glm::dvec2& p : scene::geodesicPath(measurePoints_, ring, step)) path.push_back(measurePointPosition(p));
    if (target_ && path.size() >= 2) drawLifted(path, colour, 2.5F);
  } else {
    std::vector<glm::dvec2> path = measurePoints_;
    if (ring) path.push_back(path.front());
    drawGroundPath(path, colour, 2.5F);
  }
  // The points themselves, and the length at the last one.
  const glm::dmat4 viewProj = screenViewProj();
  const glm::ivec2 fb = framebufferSize();
  const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
  ImDrawList* draw = ImGui::GetBackgroundDrawList();
  std::optional<ImVec2> last;
  for (const glm::dvec2& p : measurePoints_) {
    const glm::dvec4 clip = viewProj * glm::dvec4(measurePointPosition(p), 1.0);
    if (!(clip.w > 0.0)) continue;
    const ImVec2 at(static_cast<float>((clip.x / clip.w * 0.5 + 0.5) * fb.x) / scale.x,
                    static_cast<float>((0.5 - clip.y / clip.w * 0.5) * fb.y) / scale.y);
    draw->AddCircleFilled(at, 4.0F, colour);
    last = at;
  }
  if (measurement_ && last) {
    std::string text = formatMetres(measurement_->geodesicMetres);
    if (measurement_->geodesicAreaM2) text += ", " + formatArea(*measurement_->geodesicAreaM2);
    const ImVec2 size = ImGui::CalcTextSize(text.c_str());
    const ImVec2 at(last->x + 8.0F, last->y - size.y - 4.0F);
    draw->AddRectFilled(ImVec2(at.x - 3.0F, at.y - 2.0F), ImVec2(at.x + size.x + 3.0F, at.y + size.y + 2.0F),
                        IM_COL32(0, 0, 0, 170), 3.0F);
    draw->AddText(at, IM_COL32(255, 255, 255, 255), text.c_str());
  }
}

void Viewer::drawMeasureSection() {
  if (!ImGui::CollapsingHeader("Measure")) return;
  if (ImGui::Checkbox("measure tool (M)", &measureTool_) && measureTool_) lassoTool_ = false;
  ImGui::PushStyleColor(ImGuiCol_Text, ImGui::GetStyleColorVec4(ImGuiCol_TextDisabled));
  ImGui::TextWrapped("click points on the ground; Backspace removes the last, Esc clears");
  ImGui::PopStyleColor();
  if (ImGui::Checkbox("area (close the ring)", &measureClosed_)) remeasure();
  ImGui::SameLine();
  if (ImGui::Button("Clear##measure")) clearMeasure();
  if (!measurement_) {
    ImGui::TextDisabled("%zu point(s)", measurePoints_.size());
    return;
  }
  const scene::Measurement& m = *measurement_;
  ImGui::Text("%zu points", measurePoints_.size());
  ImGui::Text("geodesic %s", formatMetres(m.geodesicMetres).c_str());
  ImGui::Text("on the surface %s%s", formatMetres(m.surfaceMetres).c_str(),
              m.surfaceComplete ? "" : " (partly off the DEM)");
  if (globe_) {
    ImGui::TextDisabled("straight through the earth: %s", formatMetres(m.planarMetres).c_str());
  } else {
    ImGui::TextDisabled("in %s: %s", crsName().c_str(), formatMetres(m.planarMetres).c_str());
  }
  if (m.geodesicAreaM2) {
    ImGui::Text("area %s", formatArea(*m.geodesicAreaM2).c_str());
    if (m.surfaceAreaM2) ImGui::Text("surface area %s", formatArea(*m.surfaceAreaM2).c_str());
  }
}

}  // namespace gis::viewer
