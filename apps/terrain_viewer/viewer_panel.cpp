// The viewer's Dear ImGui windows: the panel (scene, view, overlay method, layers, selection),
// the HUD, the key help, identify results and the lasso being drawn.
#include <algorithm>
#include <cstdio>
#include <iterator>
#include <numbers>
#include <span>
#include <string>
#include <vector>

#include "gfx/gl.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <nlohmann/json.hpp>

#include "viewer.hpp"

#include "scene/globe_scene.hpp"

namespace gis::viewer {
namespace {

/// What a slider did in this frame.
struct SliderEdit {
  bool changed = false;  ///< the value moved
  bool done = false;     ///< released (or typed) after a change: the time to apply a costly change
  bool active = false;   ///< held (or being typed into)
  ImVec2 min, max;       ///< the slider's rectangle, window units
};

/// A slider whose value is written beside it, before its label, and not over the handle.
SliderEdit valueSlider(const char* label, float* value, float lo, float hi, const char* format,
                       ImGuiSliderFlags flags = 0) {
  SliderEdit edit;
  ImGui::PushID(label);
  edit.changed = ImGui::SliderFloat("##value", value, lo, hi, "", flags);
  edit.done = ImGui::IsItemDeactivatedAfterEdit();
  edit.active = ImGui::IsItemActive();
  edit.min = ImGui::GetItemRectMin();
  edit.max = ImGui::GetItemRectMax();
  ImGui::PopID();
  char text[48];
  std::snprintf(text, sizeof(text), format, static_cast<double>(*value));
  ImGui::SameLine(0.0F, ImGui::GetStyle().ItemInnerSpacing.x);
  ImGui::Text("%s %s", text, label);
  return edit;
}

}  // namespace

void Viewer::rememberRect(const std::string& name) {
  const ImVec2 lo = ImGui::GetItemRectMin(), hi = ImGui::GetItemRectMax();
  uiRects_[name] = {lo.x, lo.y, hi.x, hi.y};
}

void Viewer::drawPanel() {
  // A column at the left, at most the window's height (it scrolls), about 24 characters of
  // controls and their labels; the person may move and resize it.
  const ImGuiViewport* viewport = ImGui::GetMainViewport();
  const float font = ImGui::GetFontSize();
  ImGui::SetNextWindowPos(ImVec2(viewport->WorkPos.x + 10.0F, viewport->WorkPos.y + 10.0F), ImGuiCond_FirstUseEver);
  const float statusBar = ImGui::GetFrameHeight();
  ImGui::SetNextWindowSize(
      ImVec2(std::min(26.0F * font, viewport->WorkSize.x * 0.6F), viewport->WorkSize.y - 20.0F - statusBar),
      ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSizeConstraints(ImVec2(12.0F * font, 4.0F * font),
                                      ImVec2(std::max(viewport->WorkSize.x - 20.0F, 12.0F * font),
                                             std::max(viewport->WorkSize.y - 20.0F - statusBar, 4.0F * font)));
  ImGui::Begin("stencil-gis");
  panelRight_ = ImGui::GetWindowPos().x + ImGui::GetWindowSize().x;  // the home view frames the rest
  rememberWindow("panel");
  panelFont_ = font;
  ImGui::PushItemWidth(-10.0F * font);  // room for the labels
  ImGui::TextUnformatted(description_->name.empty() ? description_->path.c_str() : description_->name.c_str());
  if (ImGui::Button("Open… (Ctrl+O)")) openFileBrowser();
  ImGui::PushStyleColor(ImGuiCol_Text, ImGui::GetStyleColorVec4(ImGuiCol_TextDisabled));
  if (globe_) {
    ImGui::TextWrapped("On the globe: %s. ? lists the keys.", globeScene().reason.c_str());
  } else {
    ImGui::TextWrapped("or drop a scene, DEM or vector file on the window. ? lists the keys.");
  }
  ImGui::PopStyleColor();

  drawViewSection();
  drawOverlaySection();
  drawLayersSection();
  drawSelectionSection();
  drawMeasureSection();
  drawCacheSection();
  drawMessagesSection();
  ImGui::PopItemWidth();
  ImGui::End();
}

void Viewer::drawViewSection() {
  if (!ImGui::CollapsingHeader("View", ImGuiTreeNodeFlags_DefaultOpen)) return;
  if (ImGui::Button("Home (H)")) goHome();
  ImGui::SameLine();
  if (ImGui::Button("North up (N)")) northUp();
  ImGui::SameLine();
  bool fly = flying();
  if (ImGui::Checkbox("fly (F)", &fly)) setFlying(fly);
  if (globe_) {
    // Where the camera is about its target.
    const scene::GlobePose& pose = globe_->controller->pose();
    ImGui::Text("heading %.1f°, pitch %.1f°", pose.heading * 180.0 / std::numbers::pi,
                pose.pitch * 180.0 / std::numbers::pi);
    ImGui::Text("%s to the target", formatMetres(pose.distance).c_str());
  } else {
    // The projected camera's field of view and the terrain's level of detail (the globe's
    // tiles are chosen by their own error bound).
    float fov = static_cast<float>(settings_.fovYDeg);
    if (valueSlider("field of view", &fov, 10.0F, 90.0F, "%.0f°").changed) settings_.fovYDeg = fov;
    float tolerance = static_cast<float>(settings_.lodTolerancePixels);
    if (valueSlider("px LOD tolerance", &tolerance, 0.25F, 16.0F, "%.2f", ImGuiSliderFlags_Logarithmic).changed) {
      settings_.lodTolerancePixels = tolerance;
    }
  }
  drawExaggerationSlider();
  ImGui::Checkbox("legend", &showLegend_);
  ImGui::SameLine();
  ImGui::Checkbox("labels", &showLabels_);
  if (!globe_) {
    // The projected terrain's triangles (the globe's terrain has no wireframe).
    ImGui::SameLine();
    ImGui::Checkbox("wireframe", &render_.wireframe);
  }
  if (renderer_->hasImagery()) {
    ImGui::SameLine();
    ImGui::Checkbox("imagery", &settings_.imagery);
  }
}

void Viewer::drawOverlaySection() {
  if (!ImGui::CollapsingHeader("Overlay", ImGuiTreeNodeFlags_DefaultOpen)) return;
  ImGui::Checkbox("vector layers (O)", &render_.overlays);
  // One button per technique of the registry, two to a line; on the globe, those it does not
  // draw yet are shown disabled.
  const overlay::TechniqueInfo* chosen = technique_;
  const std::span<const overlay::TechniqueInfo> all = overlay::techniques();
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (i % 2 == 1) ImGui::SameLine();
    const bool drawn = !globe_ || scene::globeTechniqueNamed(all[i].name).has_value();
    ImGui::BeginDisabled(!drawn);
    if (ImGui::RadioButton(std::string(all[i].label).c_str(), technique_ == &all[i])) chosen = &all[i];
    ImGui::EndDisabled();
    if (!drawn && ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled)) ImGui::SetTooltip("not on the globe yet");
  }
  if (technique_->usesTextures()) drawDrapeSize();
  if (chosen != technique_) useTechnique(*chosen);
  ImGui::Checkbox("debug: pieces", &debugPieces_);
  if (debugPieces_) {
    ImGui::SameLine();
    ImGui::TextColored(ImVec4(0.1F, 0.8F, 0.2F, 1.0F), "z-pass");
    ImGui::SameLine();
    ImGui::TextColored(ImVec4(0.9F, 0.2F, 0.2F, 1.0F), "z-fail");
  }
}

void Viewer::drawDrapeSize() {
  // The baseline of other viewers, for comparison: its texels show close up. Per tile, the
  // size is each drawn chunk's texture.
  ImGui::SameLine();
  const std::string current = std::to_string(drapeSize_) + "²";
  ImGui::SetNextItemWidth(6.0F * ImGui::GetFontSize());
  if (ImGui::BeginCombo("##drape size", current.c_str())) {
    for (const int size : technique_->textureSizes) {
      if (ImGui::Selectable((std::to_string(size) + "²").c_str(), size == drapeSize_) && size != drapeSize_)
        useTechnique(*technique_, size);
    }
    ImGui::EndCombo();
  }
  if (const overlay::TextureDrape* drape = renderer_->textureDrape()) {
    // Texels in metres, or on the globe in degrees (its drapes lie in longitude and latitude).
    if (globe_) {
      ImGui::TextDisabled("%.4f° texels, %.0f MB, built in %.2f s", drape->extent().size.y / drape->size(),
                          static_cast<double>(drape->stats().gpuBytes) / 1048576.0, drape->stats().buildSeconds);
    } else {
      ImGui::TextDisabled("%.1f m texels, %.0f MB, built in %.2f s", drape->extent().size.x / drape->size(),
                          static_cast<double>(drape->stats().gpuBytes) / 1048576.0, drape->stats().buildSeconds);
    }
  } else {
    ImGui::TextDisabled("%.0f MB of tiles", static_cast<double>(renderer_->techniqueGpuBytes()) / 1048576.0);
  }
}

void Viewer::drawLayersSection() {
  if (!ImGui::CollapsingHeader("Layers", ImGuiTreeNodeFlags_DefaultOpen)) return;
  // Each scene layer alike in both frames: shown, style, categories, labels, its table.
  const std::size_t layers = description_->layers.size();
  bool rebuild = false;
  for (std::size_t i = 0; i < layers; ++i) rebuild = drawLayer(i) || rebuild;
  if (rebuild) rebuildOverlays();
}

bool Viewer::drawLayer(std::size_t i) {
  bool rebuild = false;
  ImGui::PushID(static_cast<int>(i));
  scene::LayerDescription& layer = description_->layers[i];
  const std::optional<bool> state = layerShown(i);
  const bool built = state.has_value();
  bool shown = state.value_or(false);
  if (!built) ImGui::BeginDisabled();
  if (ImGui::Checkbox("##shown", &shown)) setLayerShown(i, shown);
  if (!built) ImGui::EndDisabled();
  ImGui::SameLine();
  const scene::LayerSummary summary = renderer_->layerSummary(layer.fileIndex);
  const bool open = ImGui::TreeNode("layer", "%s (%zu features)", layer.name.c_str(), summary.features);
  if (summary.skipped() > 0 || summary.nothingToDraw > 0) {
    // Nothing is lost silently: the counts here, each feature named under Messages.
    ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1.0F, 0.75F, 0.3F, 1.0F));
    ImGui::Indent();
    ImGui::TextWrapped("%zu skipped for errors, %zu with nothing to draw", summary.skipped(), summary.nothingToDraw);
    ImGui::Unindent();
    ImGui::PopStyleColor();
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("Each is named, with its problem, under Messages.");
  }
  if (open) {
    ImGui::ColorEdit3("colour", &layer.style.color.x, ImGuiColorEditFlags_NoInputs);
    rebuild = rebuild || ImGui::IsItemDeactivatedAfterEdit();
    rebuild = valueSlider("opacity", &layer.style.opacity, 0.0F, 1.0F, "%.2f").done || rebuild;
    if (layer.kind == overlay::LayerKind::Line) {
      constexpr double kMinWidth = 0.5, kMaxWidth = 200.0;
      auto width = static_cast<float>(layer.style.widthMetres);
      const SliderEdit edit = valueSlider("m wide", &width, static_cast<float>(kMinWidth),
                                          static_cast<float>(kMaxWidth), "%.1f", ImGuiSliderFlags_Logarithmic);
      if (edit.changed) layer.style.widthMetres = width;
      rebuild = edit.done || rebuild;
    } else {
      bool outline = layer.style.outlineWidthMetres > 0.0F || layer.style.outlineWidthPixels > 0.0F;
      if (ImGui::Checkbox("outline", &outline)) {
        layer.style.outlineWidthMetres = outline ? 6.0F : 0.0F;
        layer.style.outlineWidthPixels = 0.0F;
        rebuild = true;
      }
      if (outline) {
        ImGui::SameLine();
        ImGui::ColorEdit3("##outline colour", &layer.style.outlineColor.x, ImGuiColorEditFlags_NoInputs);
        rebuild = rebuild || ImGui::IsItemDeactivatedAfterEdit();
        const bool pixels = layer.style.outlineWidthPixels > 0.0F;
        float& width = pixels ? layer.style.outlineWidthPixels : layer.style.outlineWidthMetres;
        rebuild = valueSlider(pixels ? "px outline" : "m outline", &width, pixels ? 0.5F : 0.5F,
                              pixels ? 20.0F : 100.0F, "%.1f", ImGuiSliderFlags_Logarithmic)
                      .done ||
                  rebuild;
      }
    }
    rebuild = drawCategories(i) || rebuild;
    drawLabelChoice(i);
    if (ImGui::SmallButton("attribute table")) openTable(i);
    ImGui::SameLine();
    if (ImGui::SmallButton("zoom to layer")) zoomToLayer(i);
    // Draw order: earlier layers are drawn first (below).
    if (ImGui::ArrowButton("down", ImGuiDir_Up) && i > 0) {
      std::swap(layer.style.drawOrder, description_->layers[i - 1].style.drawOrder);
      if (layer.style.drawOrder == description_->layers[i - 1].style.drawOrder) --layer.style.drawOrder;
      rebuild = true;
    }
    ImGui::SameLine();
    if (ImGui::ArrowButton("up", ImGuiDir_Down) && i + 1 < description_->layers.size()) {
      std::swap(layer.style.drawOrder, description_->layers[i + 1].style.drawOrder);
      if (layer.style.drawOrder == description_->layers[i + 1].style.drawOrder) ++layer.style.drawOrder;
      rebuild = true;
    }
    ImGui::SameLine();
    ImGui::Text("draw order %d", layer.style.drawOrder);
    ImGui::TreePop();
  }
  ImGui::PopID();
  return rebuild;
}

bool Viewer::drawCategories(std::size_t i) {
  // Colours by category: an attribute's values, each its colour (features with another value
  // keep the layer's colour).
  scene::LayerDescription& layer = description_->layers[i];
  if (featuresOf(i) == nullptr) return false;
  bool rebuild = false;
  const std::string current = layer.style.colorAttribute.empty() ? "one colour" : "by " + layer.style.colorAttribute;
  ImGui::SetNextItemWidth(12.0F * ImGui::GetFontSize());
  if (ImGui::BeginCombo("colours", current.c_str())) {
    if (ImGui::Selectable("one colour", layer.style.colorAttribute.empty()) && !layer.style.colorAttribute.empty()) {
      layer.style.colorAttribute.clear();
      layer.style.categories.clear();
      rebuild = true;
    }
    for (const std::string& name : attributeNames(i)) {
      if (ImGui::Selectable(name.c_str(), name == layer.style.colorAttribute) && name != layer.style.colorAttribute) {
        rebuild = setCategories(i, name) || rebuild;
      }
    }
    ImGui::EndCombo();
  }
  for (auto& [value, colour] : layer.style.categories) {
    ImGui::PushID(value.c_str());
    ImGui::ColorEdit3("##category", &colour.x, ImGuiColorEditFlags_NoInputs);
    rebuild = rebuild || ImGui::IsItemDeactivatedAfterEdit();
    ImGui::SameLine();
    ImGui::TextUnformatted(value.empty() ? "(empty)" : value.c_str());
    ImGui::PopID();
  }
  return rebuild;
}

void Viewer::drawLabelChoice(std::size_t i) {
  if (featuresOf(i) == nullptr) return;
  const auto current = labelSets_.find(i);
  const std::string shown = current == labelSets_.end() ? "no labels" : "labels: " + current->second.attribute;
  ImGui::SetNextItemWidth(12.0F * ImGui::GetFontSize());
  if (ImGui::BeginCombo("##labels", shown.c_str())) {
    if (ImGui::Selectable("no labels", current == labelSets_.end())) setLabels(i, "");
    for (const std::string& name : attributeNames(i)) {
      if (ImGui::Selectable(name.c_str(), current != labelSets_.end() && current->second.attribute == name)) {
        setLabels(i, name);
      }
    }
    ImGui::EndCombo();
  }
}

void Viewer::drawSelectionSection() {
  if (!ImGui::CollapsingHeader("Selection", ImGuiTreeNodeFlags_DefaultOpen)) return;
  drawLassoControls();
  if (!steps_.empty() && !selected_) ImGui::TextDisabled("finding the selected features…");
  if (selected_) {
    ImGui::Text("%zu features selected (%.0f ms)", selected_->featureCount(), selectionMs_);
    if (selected_->posts) ImGui::Text("%zu DEM posts selected", selected_->posts->selected);
    drawSelectedFeatures();
    drawExportControls();
  }
}

void Viewer::drawExportControls() {
  // The field keeps its text while it is edited; Enter exports, as the button does.
  if (!exportEditing_) std::snprintf(exportBuffer_.data(), exportBuffer_.size(), "%s", settings_.exportPath.c_str());
  const bool enter =
      ImGui::InputText("##export", exportBuffer_.data(), exportBuffer_.size(), ImGuiInputTextFlags_EnterReturnsTrue);
  exportEditing_ = ImGui::IsItemActive();
  rememberRect("export_path");
  if (ImGui::IsItemEdited() || enter) settings_.exportPath = exportBuffer_.data();
  if (enter) exportSelection(settings_.exportPath);
  if (ImGui::Button("Export GeoJSON")) exportSelection(settings_.exportPath);
}

void Viewer::drawLassoControls() {
  if (ImGui::Checkbox("lasso tool (L)", &lassoTool_) && lassoTool_) measureTool_ = false;
  rememberRect("lasso_tool");
  ImGui::PushStyleColor(ImGuiCol_Text, ImGui::GetStyleColorVec4(ImGuiCol_TextDisabled));
  ImGui::TextWrapped("drag to draw: alone a new selection, Shift or, Ctrl subtract, Ctrl+Shift and, Alt xor");
  ImGui::PopStyleColor();
  if (ImGui::Button("Invert (I)") && !steps_.empty()) invertSelection();
  ImGui::SameLine();
  if (ImGui::Button("Clear (C)")) clearSelection();
  ImGui::SameLine();
  ImGui::ColorEdit3("highlight", &highlight_.color.x, ImGuiColorEditFlags_NoInputs);
  ImGui::BeginDisabled(undo_.empty());
  if (ImGui::Button("Undo (Ctrl+Z)")) undoSelection();
  ImGui::EndDisabled();
  ImGui::SameLine();
  ImGui::BeginDisabled(redo_.empty());
  if (ImGui::Button("Redo (Ctrl+Y)")) redoSelection();
  ImGui::EndDisabled();
  if (!steps_.empty()) {
    std::string chain;
    for (const overlay::SelectionStep& s : steps_)
      chain += std::string(chain.empty() ? "" : " → ") + overlay::selectionOpName(s.op);
    ImGui::TextWrapped("steps: %s", chain.c_str());
  }
}

void Viewer::drawSelectedFeatures() {
  for (const scene::SelectedFeatures::Layer& l : selected_->layers) {
    if (!ImGui::TreeNode(&l, "%s: %zu (%zu fully inside)", l.name.c_str(), l.features.size(), l.fullyInside)) continue;
    const std::size_t shown = std::min<std::size_t>(l.features.size(), 200);
    for (std::size_t k = 0; k < shown; ++k) {
      const overlay::FeatureSelection& f = l.features[k];
      if (ImGui::TreeNode(&f, "fid %lld%s", static_cast<long long>(l.fids[k]), f.fullyInside ? " (inside)" : "")) {
        // Read when opened: a layer's features may be on disk.
        if (const std::shared_ptr<const geo::Feature> feature = featureAt(l.sceneLayer, f.feature)) {
          for (const auto& [key, value] : feature->attributes)
            ImGui::BulletText("%s: %s", key.c_str(), attributeText(value).c_str());
        }
        ImGui::TreePop();
      }
    }
    if (shown < l.features.size()) ImGui::TextDisabled("… and %zu more", l.features.size() - shown);
    ImGui::TreePop();
  }
}

void Viewer::drawCacheSection() {
  if (!description_ || !ImGui::CollapsingHeader("Cache")) return;
  // Counted when the section is open, at most every 3 s (a large cache is a walk of its folders).
  const auto now = std::chrono::steady_clock::now();
  if (!cacheShown_ || now - cacheShown_->counted > std::chrono::seconds(3)) {
    const std::string directory = scene::cacheDirectoryFor(*description_);
    cacheShown_ = CacheShown{directory, scene::cacheUsage(directory), now};
  }
  if (cacheShown_->directory.empty()) {
    ImGui::TextWrapped("no cache: the scene's folder and the user's cache folder cannot be written");
    return;
  }
  ImGui::TextWrapped("%s", cacheShown_->directory.c_str());
  ImGui::Text("%zu files, %.1f MB", cacheShown_->usage.files, static_cast<double>(cacheShown_->usage.bytes) / 1e6);
  if (ImGui::Button("Clear cache")) {
    const scene::CacheUsage removed = scene::clearCache(cacheShown_->directory);
    notify("Cache cleared: " + std::to_string(removed.files) + " files, " +
           std::to_string(static_cast<long long>(static_cast<double>(removed.bytes) / 1e6 + 0.5)) +
           " MB (built again as needed)");
    cacheShown_.reset();
  }
}

void Viewer::drawMessagesSection() {
  if (messages_.empty() || !ImGui::CollapsingHeader("Messages")) return;
  for (std::size_t k = messages_.size() > 30 ? messages_.size() - 30 : 0; k < messages_.size(); ++k) {
    const auto repeats = said_.find(messages_[k]);
    if (repeats != said_.end() && repeats->second > 1) {
      ImGui::TextWrapped("%s (×%zu)", messages_[k].c_str(), repeats->second);
    } else {
      ImGui::TextWrapped("%s", messages_[k].c_str());
    }
  }
}

std::uint64_t Viewer::overlayFragments() const {
  std::uint64_t fragments = 0;
  for (const scene::FrameFigures::LayerPasses& l : figures_.layers) fragments += l.markFragments + l.coverFragments;
  return fragments;
}

nlohmann::json Viewer::windowsJson() const {
  nlohmann::json windows = nlohmann::json::object();
  for (const auto& [name, r] : windowRects_) windows[name] = {r.x, r.y, r.z, r.w};
  return windows;
}

void Viewer::beginHud() {
  const ImGuiViewport* viewport = ImGui::GetMainViewport();
  ImGui::SetNextWindowPos(ImVec2(viewport->WorkPos.x + viewport->WorkSize.x - 10, viewport->WorkPos.y + 10),
                          ImGuiCond_Always, ImVec2(1.0F, 0.0F));
  ImGui::SetNextWindowBgAlpha(0.55F);
  ImGui::Begin("HUD", nullptr,
               ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoFocusOnAppearing |
                   ImGuiWindowFlags_NoNav | ImGuiWindowFlags_NoInputs);
  rememberWindow("hud");
  ImGui::Text("%.1f fps  %.1f ms", 1000.0 / std::max(frameMs_, 1e-3), frameMs_);
}

void Viewer::drawHud() {
  beginHud();
  // What the frame drew and cost, in its renderer's figures (the same in both frames); then where
  // the eye is.
  const scene::FrameFigures& f = figures_;
  ImGui::Text("terrain: %zu triangles, %zu %s, GPU %.2f ms", f.terrain.triangles, f.terrain.tiles,
              globe_ ? "tiles" : "chunks", f.terrainGpuMs);
  if (!render_.overlays) {
    ImGui::TextColored(ImVec4(1.0F, 0.8F, 0.2F, 1.0F), "overlays off (O)");
  } else if (f.draped) {
    ImGui::Text("overlays: draped by the terrain, %zu textures built, %.0f MB", f.texturesBuilt,
                static_cast<double>(f.drapeBytes) / 1048576.0);
  } else {
    ImGui::Text("overlays: GPU %.2f ms, %.2f M fragments, %zu pieces, %zu z-fail", f.overlayGpuMs,
                static_cast<double>(overlayFragments()) * 1e-6, f.drawnPieces, f.zFailPieces);
    // Each shown layer's passes.
    for (std::size_t j = 0; j < renderer_->drawnLayerCount() && j < f.layers.size(); ++j) {
      if (!renderer_->drawnLayerShown(j)) continue;
      const scene::FrameFigures::LayerPasses& l = f.layers[j];
      ImGui::TextDisabled("  %s: %.2f ms, %zu pieces", renderer_->drawnLayerName(j).c_str(), l.gpuMs, l.pieces);
    }
    if (f.deferredPending > 0) {
      ImGui::TextColored(ImVec4(1.0F, 0.8F, 0.2F, 1.0F), "deferred lookup: %zu index%s building (drawn as pieces)",
                         f.deferredPending, f.deferredPending == 1 ? "" : "es");
    }
    if (f.deferredLayers > 0) {
      ImGui::Text("deferred lookup: %zu layer%s, %.0f MB of indices", f.deferredLayers,
                  f.deferredLayers == 1 ? "" : "s", static_cast<double>(f.deferredBytes) / 1048576.0);
    }
  }
  if (globe_) {
    const globe::Geodetic eye = globe::toGeodetic(globe_->controller->eye());
    ImGui::Text("eye: lon %.6f°, lat %.6f°", eye.lon, eye.lat);
    ImGui::Text("     %s above ground, %s above the ellipsoid",
                formatMetres(globe_->controller->heightAboveGround()).c_str(), formatMetres(eye.h).c_str());
  } else {
    if (projected().paged()) {
      ImGui::Text("tiles: %zu resident, %zu loading", f.terrainResidentTiles, f.terrainPending);
    }
    const scene::Camera c = camera();
    if (const std::optional<glm::dvec3> ll =
            projected().frame.toLonLat(c.eye / glm::dvec3(1, 1, projected().bounds->exaggeration()))) {
      ImGui::Text("eye: %s, height %.0f m", formatLonLat(*ll).c_str(), ll->z);
    }
  }
  ImGui::End();
}

void Viewer::drawNoScene() {
  const ImVec2 size = ImGui::GetMainViewport()->Size;
  ImGui::SetNextWindowPos(ImGui::GetMainViewport()->GetCenter(), ImGuiCond_Always, ImVec2(0.5F, 0.5F));
  ImGui::SetNextWindowSize(ImVec2(size.x * 0.8F, size.y * 0.6F), ImGuiCond_Always);
  ImGui::Begin("Nothing to show", nullptr, ImGuiWindowFlags_NoCollapse | ImGuiWindowFlags_NoMove);
  ImGui::TextWrapped(
      "Drop on this window a scene file (.json), a DEM (a GeoTIFF, SRTM .hgt or any raster GDAL reads, in any CRS; "
      "a folder of tiles; a VRT) or a vector file (shown over flat ground).");
  if (ImGui::Button("Open… (Ctrl+O)")) openFileBrowser();
  ImGui::Separator();
  for (std::size_t k = messages_.size() > 30 ? messages_.size() - 30 : 0; k < messages_.size(); ++k) {
    const bool error = messages_[k].rfind("error", 0) == 0;
    if (error) ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1.0F, 0.45F, 0.4F, 1.0F));
    ImGui::TextWrapped("%s", messages_[k].c_str());
    if (error) ImGui::PopStyleColor();
  }
  ImGui::End();
}

void drawKeysWindow(const char* title, bool* open, std::span<const std::array<const char*, 2>> rows) {
  ImGui::SetNextWindowPos(ImGui::GetMainViewport()->GetCenter(), ImGuiCond_Appearing, ImVec2(0.5F, 0.5F));
  ImGui::Begin(title, open, ImGuiWindowFlags_AlwaysAutoResize);
  if (ImGui::BeginTable("keys", 2)) {
    for (const auto& row : rows) {
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(row[0]);
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(row[1]);
    }
    ImGui::EndTable();
  }
  ImGui::End();
}

void Viewer::drawHelp() {
  // The camera's rows are the frame's (a projected scene orbits and pans, the globe is grabbed);
  // the tools' are the same in both.
  static const std::array<const char*, 2> kProjected[] = {
      {"left drag", "orbit around the point in view (fly mode: look)"},
      {"right / middle drag", "pan: the ground under the cursor follows it"},
      {"wheel", "zoom to the point under the cursor"},
  };
  static const std::array<const char*, 2> kGlobe[] = {
      {"left drag", "grab the globe: it spins from space, pans near the ground (fly mode: look)"},
      {"right / middle drag, Ctrl+left drag", "orbit about the target: heading and pitch"},
      {"wheel", "zoom to the point under the cursor (space to 1 m above the ground)"},
      {"arrows", "turn (left, right) and tilt (up, down)"},
      {"Page Up / Page Down", "zoom in / out at the centre"},
  };
  static const std::array<const char*, 2> kTools[] = {
      {"click", "identify: features, coordinates and height under the cursor"},
      {"F", "fly mode: W A S D move, Q E down/up, Shift faster, drag to look"},
      {"H / Home", "home view"},
      {"N", "north up (or click the compass)"},
      {"L", "lasso tool: drag to draw; Shift or, Ctrl subtract, Ctrl+Shift and, Alt xor"},
      {"I / C", "invert / clear the selection"},
      {"M", "measure tool: click points (geodesic and surface lengths; the area with the ring closed)"},
      {"Backspace", "remove the last measured point"},
      {"Ctrl+Z / Ctrl+Y", "undo / redo a step of the selection"},
      {"O", "all vector layers on/off (compare frame rate)"},
      {"P / U", "panel / HUD on/off"},
      {"Ctrl+O", "open a scene, DEM or vector file"},
      {"F12", "screenshot (PNG, working directory)"},
      {"?", "this help"},
      {"Esc", "drop the lasso being drawn, the lasso tool, the measured points, the measure tool, help or identify"},
      {"Ctrl+Q", "quit"},
  };
  std::vector<std::array<const char*, 2>> rows;
  if (globe_) {
    rows.assign(std::begin(kGlobe), std::end(kGlobe));
  } else {
    rows.assign(std::begin(kProjected), std::end(kProjected));
  }
  rows.insert(rows.end(), std::begin(kTools), std::end(kTools));
  drawKeysWindow("Keys and mouse (?)", &showHelp_, rows);
}

void Viewer::drawIdentify() {
  if (!identified_) return;
  bool open = true;
  const ImGuiViewport* viewport = ImGui::GetMainViewport();
  // Above the compass and the status bar.
  const float above = ImGui::GetFrameHeight() + 6.5F * ImGui::GetFontSize() + 10.0F;
  ImGui::SetNextWindowPos(
      ImVec2(viewport->WorkPos.x + viewport->WorkSize.x - 10.0F, viewport->WorkPos.y + viewport->WorkSize.y - above),
      ImGuiCond_FirstUseEver, ImVec2(1.0F, 1.0F));
  ImGui::Begin("Identify", &open, ImGuiWindowFlags_AlwaysAutoResize);
  rememberWindow("identify");
  // Where: in each frame's own terms (the globe has no projected coordinates); then the features.
  const Identified& id = *identified_;
  if (id.point.lonLatH) ImGui::TextUnformatted(formatLonLat(*id.point.lonLatH).c_str());
  if (id.point.projected)
    ImGui::Text("%s: E %.2f, N %.2f", crsName().c_str(), id.point.projected->x, id.point.projected->y);
  ImGui::Text("height %.2f m%s (terrain %.2f m)", id.point.height, id.point.onGlobe ? " above the ellipsoid" : "",
              id.terrainHeight);
  if (id.hits.empty()) ImGui::TextDisabled("no feature here");
  for (const Identified::Hit& h : id.hits) {
    if (ImGui::TreeNodeEx(&h, ImGuiTreeNodeFlags_DefaultOpen, "%s: fid %lld", h.layer.c_str(),
                          static_cast<long long>(h.fid))) {
      for (const auto& [k, v] : h.attributes) ImGui::BulletText("%s: %s", k.c_str(), v.c_str());
      ImGui::TreePop();
    }
  }
  ImGui::End();
  if (open) return;
  identified_.reset();
}

void Viewer::drawLassoOutline() {
  if (lassoPoints_.size() < 2) return;
  // Framebuffer pixels → ImGui's coordinates (window units).
  const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
  std::vector<ImVec2> points;
  points.reserve(lassoPoints_.size());
  for (const glm::dvec2& p : lassoPoints_) {
    points.emplace_back(static_cast<float>(p.x) / scale.x, static_cast<float>(p.y) / scale.y);
  }
  ImGui::GetForegroundDrawList()->AddPolyline(points.data(), static_cast<int>(points.size()),
                                              IM_COL32(255, 230, 40, 255), ImDrawFlags_Closed, 2.0F);
}

void Viewer::drawExaggerationSlider() {
  // The pieces' heights follow the exaggeration at release; until then the slider keeps the
  // value being dragged (it must not snap back to the applied one).
  float value = exaggerationEdit_.value_or(static_cast<float>(exaggeration()));
  const SliderEdit edit = valueSlider("exaggeration", &value, 0.1F, 20.0F, "%.1f×", ImGuiSliderFlags_Logarithmic);
  uiRects_["exaggeration"] = {edit.min.x, edit.min.y, edit.max.x, edit.max.y};
  if (edit.changed) exaggerationEdit_ = value;
  if (edit.done) {
    setExaggeration(value);
    exaggerationEdit_.reset();
  } else if (!edit.active) {
    exaggerationEdit_.reset();
  }
}

}  // namespace gis::viewer
