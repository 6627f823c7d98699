// What a map shows around the scene: the coordinates under the cursor (a status bar), a scale
// bar, and a compass that turns the view north-up when clicked (key N).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

#include "gfx/gl.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>

#include "terrain/elevation_ramp.hpp"
#include "viewer.hpp"

namespace gis::viewer {

std::string formatLonLat(const glm::dvec3& lonLatH) {
  char text[64];
  std::snprintf(text, sizeof(text), "lon %.6f°, lat %.6f°", lonLatH.x, lonLatH.y);
  return text;
}

std::string formatMetres(double metres) {
  char text[32];
  if (std::abs(metres) >= 10000.0) {
    std::snprintf(text, sizeof(text), "%.1f km", metres / 1000.0);
  } else if (std::abs(metres) >= 100.0) {
    std::snprintf(text, sizeof(text), "%.0f m", metres);
  } else {
    std::snprintf(text, sizeof(text), "%.2f m", metres);
  }
  return text;
}

std::string formatArea(double squareMetres) {
  char text[32];
  if (squareMetres >= 1e6) {
    std::snprintf(text, sizeof(text), "%.2f km²", squareMetres / 1e6);
  } else if (squareMetres >= 1e4) {
    std::snprintf(text, sizeof(text), "%.2f ha", squareMetres / 1e4);
  } else {
    std::snprintf(text, sizeof(text), "%.0f m²", squareMetres);
  }
  return text;
}

float outlineWidthFor(double acrossPixels) {
  if (!(acrossPixels >= 3.0)) return 0.0F;
  return static_cast<float>(std::clamp(acrossPixels / 12.0, 1.0, 2.5));
}

double niceLength(double most) {
  // The largest 1, 2 or 5 × 10^k not above `most`.
  if (!(most > 0.0) || !std::isfinite(most)) return 0.0;
  const double decade = std::pow(10.0, std::floor(std::log10(most)));
  for (const double m : {5.0, 2.0, 1.0}) {
    if (m * decade <= most) return m * decade;
  }
  return decade;
}

std::optional<double> Viewer::metresPerPixelAtCentre() const {
  const glm::ivec2 fb = framebufferSize();
  const std::optional<glm::dvec3> centre = pointAt(glm::dvec2(fb) * 0.5);
  if (!centre || fb.y <= 0) return std::nullopt;
  const overlay::OverlayView v = scene::Scene::overlayViewOf(frameCamera(), fb.x, fb.y);
  // The pixel's size at the centre's distance along the view axis (clip w), in either frame
  // (horizontal lengths are not exaggerated).
  const double depth = (v.viewProj * glm::dvec4(*centre, 1.0)).w;
  return depth * 2.0 * std::tan(0.5 * v.fovYRadians) / fb.y;
}

std::optional<double> Viewer::northYaw() const {
  // True north at the view's centre (grid north differs by the meridian convergence).
  const scene::Camera c = camera();
  const glm::dvec3 at(c.target.x, c.target.y, 0.0);
  const std::optional<glm::dvec3> ll = projected().frame.toLonLat(at);
  if (!ll) return std::nullopt;
  const std::optional<glm::dvec3> north = projected().frame.fromLonLat(ll->x, std::min(ll->y + 0.001, 89.999), 0.0);
  if (!north) return std::nullopt;
  const glm::dvec2 n = glm::dvec2(*north) - glm::dvec2(at);
  if (glm::length(n) <= 0.0) return std::nullopt;
  // OrbitPose::yaw looks along (−sin yaw, cos yaw).
  return std::atan2(-n.x, n.y);
}

void Viewer::northUp() {
  if (globe_) {
    globe_->controller->northUp();
    return;
  }
  if (const std::optional<double> yaw = northYaw()) controller_->setHeading(*yaw);
}

void Viewer::drawElevationLegend() {
  if (!render_.elevationRamp) return;
  // The terrain's tint by height: a bar from the lowest to the highest post, as on flat ground.
  const auto [low, high] = *render_.elevationRamp;
  ImGui::Separator();
  ImGui::TextUnformatted("terrain height");
  const terrain::ElevationRamp& ramp = terrain::ElevationRamp::hypsometric();
  const float width = 10.0F * ImGui::GetFontSize(), height = ImGui::GetTextLineHeight();
  const ImVec2 p = ImGui::GetCursorScreenPos();
  ImDrawList* draw = ImGui::GetWindowDrawList();
  constexpr int kSteps = 48;
  for (int k = 0; k < kSteps; ++k) {
    const glm::vec3 c = ramp.colorAt((k + 0.5) / kSteps);
    const float x0 = p.x + width * static_cast<float>(k) / kSteps,
                x1 = p.x + width * static_cast<float>(k + 1) / kSteps;
    draw->AddRectFilled(ImVec2(x0, p.y), ImVec2(x1 + 0.5F, p.y + height),
                        ImGui::ColorConvertFloat4ToU32(ImVec4(c.x, c.y, c.z, 1.0F)));
  }
  ImGui::Dummy(ImVec2(width, height));
  ImGui::Text("%.0f m", low);
  ImGui::SameLine(std::max(width - ImGui::CalcTextSize("0000 m").x, 0.0F));
  ImGui::Text("%.0f m", high);
}

void Viewer::drawStatusBar() {
  const ImGuiViewport* viewport = ImGui::GetMainViewport();
  const float height = ImGui::GetFrameHeight();
  ImGui::SetNextWindowPos(ImVec2(viewport->WorkPos.x, viewport->WorkPos.y + viewport->WorkSize.y - height),
                          ImGuiCond_Always);
  ImGui::SetNextWindowSize(ImVec2(viewport->WorkSize.x, height), ImGuiCond_Always);
  ImGui::SetNextWindowBgAlpha(0.6F);
  ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2(8.0F, 2.0F));
  ImGui::PushStyleVar(ImGuiStyleVar_WindowRounding, 0.0F);
  ImGui::Begin("status", nullptr,
               ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoInputs | ImGuiWindowFlags_NoFocusOnAppearing |
                   ImGuiWindowFlags_NoNav | ImGuiWindowFlags_NoSavedSettings);
  rememberWindow("status");
  if (notice_) {
    // A notice (a screenshot or an export saved, an action that failed) takes the status bar's
    // line for a few seconds: it covers neither the scene nor the legend and the HUD. A text
    // longer than the line keeps its end (a path's file name), the whole of it is in the log.
    const float room = ImGui::GetContentRegionAvail().x;
    std::string text = notice_->text;
    if (ImGui::CalcTextSize(text.c_str()).x > room) {
      std::size_t from = 0;
      const auto next = [&] {  // the next character's first byte (UTF-8)
        ++from;
        while (from < text.size() && (static_cast<unsigned char>(text[from]) & 0xC0U) == 0x80U) ++from;
      };
      while (from < text.size() && ImGui::CalcTextSize(("..." + text.substr(from)).c_str()).x > room) next();
      text = "..." + text.substr(from);
    }
    if (notice_->error) {
      ImGui::TextColored(ImVec4(1.0F, 0.45F, 0.4F, 1.0F), "%s", text.c_str());
    } else {
      ImGui::TextUnformatted(text.c_str());
    }
  } else if (cursorGround_) {
    const GroundPoint& g = *cursorGround_;
    const std::string ll = g.lonLatH ? formatLonLat(*g.lonLatH) + "   " : std::string();
    if (g.projected) {
      ImGui::Text("%s%s E %.1f, N %.1f   height %.2f m", ll.c_str(), crsName().c_str(), g.projected->x, g.projected->y,
                  g.height);
    } else {
      ImGui::Text("%sheight %.2f m (WGS 84 ellipsoid)", ll.c_str(), g.height);
    }
  } else {
    ImGui::TextDisabled(globe_ ? "move the cursor over the globe for its coordinates"
                               : "move the cursor over the terrain for its coordinates");
  }
  ImGui::End();
  ImGui::PopStyleVar(2);
}

void Viewer::drawScaleBar() {
  const std::optional<double> perPixel = metresPerPixelAtCentre();
  if (!perPixel || !(*perPixel > 0.0)) return;
  const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
  // At most 150 window units long; metres per window unit = per pixel × framebuffer scale.
  const double perUnit = *perPixel * static_cast<double>(scale.x);
  const double metres = niceLength(150.0 * perUnit);
  if (metres <= 0.0) return;
  const auto length = static_cast<float>(metres / perUnit);
  const ImGuiViewport* viewport = ImGui::GetMainViewport();
  const float font = ImGui::GetFontSize();
  // In the part of the window the panel leaves free.
  const float x0 = viewport->WorkPos.x + static_cast<float>(freeRegion().x) / scale.x + 12.0F;
  const float y0 = viewport->WorkPos.y + viewport->WorkSize.y - ImGui::GetFrameHeight() - 10.0F;
  ImDrawList* draw = ImGui::GetBackgroundDrawList();
  const std::string label = formatMetres(metres) + " (at the centre)";
  draw->AddRectFilled(ImVec2(x0 - 4.0F, y0 - font - 10.0F),
                      ImVec2(x0 + std::max(length, ImGui::CalcTextSize(label.c_str()).x) + 4.0F, y0 + 4.0F),
                      IM_COL32(0, 0, 0, 110), 3.0F);
  const ImU32 white = IM_COL32(255, 255, 255, 235);
  draw->AddLine(ImVec2(x0, y0), ImVec2(x0 + length, y0), white, 2.0F);
  draw->AddLine(ImVec2(x0, y0), ImVec2(x0, y0 - 6.0F), white, 2.0F);
  draw->AddLine(ImVec2(x0 + length, y0), ImVec2(x0 + length, y0 - 6.0F), white, 2.0F);
  draw->AddText(ImVec2(x0, y0 - font - 8.0F), white, label.c_str());
  scaleBarMetres_ = metres;
}

void Viewer::drawCompass() {
  // On screen, north is turned clockwise from up by how far the view is turned from north (on
  // the globe: the heading, clockwise from north).
  double screenAngle = 0.0;
  if (globe_) {
    screenAngle = -globe_->controller->heading();
  } else if (const std::optional<double> yawNorth = northYaw()) {
    screenAngle = controller_->shownPose().yaw - *yawNorth;
  } else {
    return;
  }
  const ImGuiViewport* viewport = ImGui::GetMainViewport();
  const float radius = 1.6F * ImGui::GetFontSize();
  const float margin = ImGui::GetFontSize() + 10.0F;
  const ImVec2 centre(viewport->WorkPos.x + viewport->WorkSize.x - radius - margin,
                      viewport->WorkPos.y + viewport->WorkSize.y - ImGui::GetFrameHeight() - radius - margin);
  // A small window of its own, so a click on it is the panel's and not an identify; room for
  // the N around the dial.
  const float half = radius + ImGui::GetFontSize();
  ImGui::SetNextWindowPos(ImVec2(centre.x - half, centre.y - half), ImGuiCond_Always);
  ImGui::SetNextWindowSize(ImVec2(2.0F * half, 2.0F * half), ImGuiCond_Always);
  ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2(0.0F, 0.0F));
  ImGui::Begin("compass", nullptr,
               ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoBackground | ImGuiWindowFlags_NoFocusOnAppearing |
                   ImGuiWindowFlags_NoNav | ImGuiWindowFlags_NoSavedSettings);
  if (ImGui::InvisibleButton("north up", ImVec2(2.0F * half, 2.0F * half))) northUp();
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("north up (N)");
  ImDrawList* draw = ImGui::GetWindowDrawList();
  draw->AddCircleFilled(centre, radius, IM_COL32(20, 22, 28, 170));
  draw->AddCircle(centre, radius, IM_COL32(255, 255, 255, 200), 0, 1.5F);
  const auto at = [&](double angle, float r) {
    return ImVec2(centre.x + r * static_cast<float>(std::sin(angle)),
                  centre.y - r * static_cast<float>(std::cos(angle)));
  };
  const double a = screenAngle;
  const float r = radius * 0.8F;
  draw->AddTriangleFilled(at(a, r), at(a + 2.6, r * 0.45F), at(a - 2.6, r * 0.45F), IM_COL32(230, 60, 50, 255));
  draw->AddTriangleFilled(at(a + std::numbers::pi, r), at(a + 2.6, r * 0.45F), at(a - 2.6, r * 0.45F),
                          IM_COL32(220, 220, 220, 255));
  const ImVec2 n = at(a, radius + 0.5F * ImGui::GetFontSize());
  const ImVec2 size = ImGui::CalcTextSize("N");
  draw->AddText(ImVec2(n.x - size.x * 0.5F, n.y - size.y * 0.5F), IM_COL32(255, 255, 255, 255), "N");
  ImGui::End();
  ImGui::PopStyleVar();
  compassAngle_ = screenAngle;
}

}  // namespace gis::viewer
