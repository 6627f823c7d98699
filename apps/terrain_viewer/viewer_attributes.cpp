// The layers' attributes in the viewer: a table per layer (sort, search, rows selected with the
// map), zoom to a feature or a layer, the legend, and the highlighted features drawn on the map
// by their own outlines.
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <string>
#include <type_traits>
#include <variant>

#include "gfx/gl.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_internal.h>  // TableSetColumnSortDirection: a sort set by a script shows in the headers
#include <glm/geometric.hpp>

#include "gfx/render_target.hpp"
#include "viewer.hpp"

namespace gis::viewer {
namespace {

std::string lowerCase(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

/// Numbers before text, numbers by value, text by its characters; empty values last.
int compareValues(const geo::AttributeValue& a, const geo::AttributeValue& b) {
  const auto number = [](const geo::AttributeValue& v) -> std::optional<double> {
    if (const auto* i = std::get_if<std::int64_t>(&v)) return static_cast<double>(*i);
    if (const auto* d = std::get_if<double>(&v)) return *d;
    return std::nullopt;
  };
  const bool emptyA = std::holds_alternative<std::monostate>(a), emptyB = std::holds_alternative<std::monostate>(b);
  if (emptyA || emptyB) return emptyA == emptyB ? 0 : (emptyA ? 1 : -1);
  const std::optional<double> na = number(a), nb = number(b);
  if (na && nb) return *na < *nb ? -1 : (*nb < *na ? 1 : 0);
  if (na || nb) return na ? -1 : 1;
  return std::get<std::string>(a).compare(std::get<std::string>(b));
}

}  // namespace

std::string attributeText(const geo::AttributeValue& value) {
  return std::visit(
      [](const auto& x) -> std::string {
        using T = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<T, std::monostate>) {
          return "";
        } else if constexpr (std::is_same_v<T, std::string>) {
          return x;
        } else if constexpr (std::is_same_v<T, std::int64_t>) {
          return std::to_string(x);
        } else {
          char text[32];
          std::snprintf(text, sizeof(text), "%.10g", x);
          return text;
        }
      },
      value);
}

std::optional<std::size_t> Viewer::fillLayerOf(std::size_t sceneLayer) const {
  for (const std::size_t j : drawnLayersOf(sceneLayer)) {
    if (!renderer_->drawnLayerSource(j).outline) return j;
  }
  return std::nullopt;
}

const std::vector<geo::Feature>* Viewer::featuresOf(std::size_t sceneLayer) const {
  // The features every drawn layer of this scene layer was built from (a fill and its outline
  // share them).
  const std::vector<std::size_t> drawn = drawnLayersOf(sceneLayer);
  return drawn.empty() ? nullptr : renderer_->drawnLayerFeatures(drawn.front());
}

std::shared_ptr<const geo::Feature> Viewer::featureAt(std::size_t sceneLayer, std::size_t feature) const {
  const std::vector<std::size_t> drawn = drawnLayersOf(sceneLayer);
  return drawn.empty() ? nullptr : renderer_->drawnLayerFeature(drawn.front(), feature);
}

std::vector<std::size_t> Viewer::drawnLayersOf(std::size_t sceneLayer) const {
  std::vector<std::size_t> out;
  if (!renderer_ || !description_ || sceneLayer >= description_->layers.size()) return out;
  const std::size_t fileIndex = description_->layers[sceneLayer].fileIndex;
  for (std::size_t j = 0; j < renderer_->drawnLayerCount(); ++j)
    if (renderer_->drawnLayerSource(j).fileIndex == fileIndex) out.push_back(j);
  return out;
}

std::string Viewer::sceneLayerNameOf(std::size_t drawn) const {
  const std::size_t fileIndex = renderer_->drawnLayerSource(drawn).fileIndex;
  for (const scene::LayerDescription& d : description_->layers)
    if (d.fileIndex == fileIndex) return d.name;
  return renderer_->drawnLayerName(drawn);
}

std::vector<std::string> Viewer::attributeNames(std::size_t sceneLayer) const {
  std::set<std::string> names;
  if (const std::vector<geo::Feature>* features = featuresOf(sceneLayer)) {
    for (const geo::Feature& f : *features) {
      for (const auto& [key, value] : f.attributes) names.insert(key);
    }
  }
  return {names.begin(), names.end()};
}

void Viewer::zoomToBox(glm::dvec3 lo, glm::dvec3 hi) {
  // Heights from the terrain over the box (as drawn), so a feature on a hill is framed with it.
  double zLo = std::numeric_limits<double>::infinity(), zHi = -zLo;
  for (int i = 0; i <= 8; ++i) {
    for (int k = 0; k <= 8; ++k) {
      const double h = projected().bounds->fullResolutionHeightAt(glm::dvec2(lo) + (glm::dvec2(hi) - glm::dvec2(lo)) *
                                                                                       glm::dvec2(i / 8.0, k / 8.0));
      if (std::isfinite(h)) {
        zLo = std::min(zLo, h);
        zHi = std::max(zHi, h);
      }
    }
  }
  if (!std::isfinite(zLo)) zLo = zHi = 0.0;
  lo.z = zLo;
  hi.z = zHi;
  // A small feature is framed with some ground around it.
  const glm::dvec2 size = glm::dvec2(hi) - glm::dvec2(lo);
  const double least = std::max({size.x, size.y, 50.0});
  const glm::dvec2 grow = glm::max(glm::dvec2(0.0), glm::dvec2(least) - size) * 0.5 + 0.1 * glm::dvec2(least);
  lo -= glm::dvec3(grow, 0.0);
  hi += glm::dvec3(grow, 0.0);
  scene::Camera from = controller_->goal();
  from.fovYDeg = settings_.fovYDeg;
  // Keep the heading; look down at least 35° so the feature is not hidden behind its hills.
  glm::dvec3 direction = glm::normalize(from.target - from.eye);
  const double down = std::asin(std::clamp(-direction.z, -1.0, 1.0));
  if (down < 0.61) {
    const glm::dvec2 heading =
        glm::length(glm::dvec2(direction)) > 1e-9 ? glm::normalize(glm::dvec2(direction)) : glm::dvec2(0.0, 1.0);
    direction = glm::dvec3(heading * std::cos(0.61), -std::sin(0.61));
  }
  from.target = 0.5 * (lo + hi);
  from.eye = from.target - direction * glm::length(hi - lo);
  const scene::Camera framed = scene::frameBoxInRegion(from, lo, hi, framebufferSize(), freeRegion());
  controller_->animateTo(framed, 1.0);
}

void Viewer::zoomToFeatures(std::size_t sceneLayer, const std::vector<std::size_t>& features) {
  glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  const std::vector<geo::Feature>* drawn = featuresOf(sceneLayer);
  if (drawn == nullptr) return;
  const std::vector<geo::Feature>& all = *drawn;
  // On the globe each point's longitude is unwrapped next to the previous point's, so data
  // across ±180° gets its narrow box, not one around the world.
  std::optional<double> previous;
  const auto add = [&](glm::dvec2 v) {
    if (globe_ && previous) v.x += 360.0 * std::round((*previous - v.x) / 360.0);
    previous = v.x;
    lo = glm::min(lo, v);
    hi = glm::max(hi, v);
  };
  for (const std::size_t f : features) {
    if (f >= all.size()) continue;
    for (const geo::Polygon& p : all[f].polygons) {
      for (const glm::dvec2& v : p.outer) add(v);
    }
    for (const geo::LineString& l : all[f].lines) {
      for (const glm::dvec2& v : l) add(v);
    }
  }
  if (!(lo.x <= hi.x)) return;
  if (globe_) {
    // Longitude and latitude: framed from above in the free part of the window (a small
    // feature with some ground around it, as in a projected frame).
    const double grow = std::max({hi.x - lo.x, hi.y - lo.y, 50.0 / kMetresPerDegree}) * 0.1;
    const glm::ivec2 fb = framebufferSize();
    globe_->controller->home(lo.x - grow, std::max(lo.y - grow, -90.0), hi.x + grow, std::min(hi.y + grow, 90.0),
                             glm::ivec2(std::max(fb.x, 1), std::max(fb.y, 1)), freeRegion());
    return;
  }
  zoomToBox(glm::dvec3(lo, 0.0), glm::dvec3(hi, 0.0));
}

void Viewer::zoomToLayer(std::size_t sceneLayer) {
  const std::vector<geo::Feature>* features = featuresOf(sceneLayer);
  if (features == nullptr) return;
  std::vector<std::size_t> every(features->size());
  for (std::size_t f = 0; f < every.size(); ++f) every[f] = f;
  zoomToFeatures(sceneLayer, every);
}

bool Viewer::setCategories(std::size_t sceneLayer, const std::string& attribute) {
  const std::vector<geo::Feature>* features = featuresOf(sceneLayer);
  if (features == nullptr) return false;
  std::set<std::string> values;
  for (const geo::Feature& f : *features) {
    const auto v = f.attributes.find(attribute);
    values.insert(v == f.attributes.end() ? std::string() : attributeText(v->second));
    if (values.size() > kMaxCategories) break;
  }
  if (values.size() > kMaxCategories) {
    message(description_->layers[sceneLayer].name + ": " + attribute + " has more than " +
                std::to_string(kMaxCategories) + " values: too many to colour by category",
            true);
    return false;
  }
  // A qualitative palette (distinct hues, similar lightness), repeated with darker shades.
  static constexpr std::array<glm::vec3, 10> kPalette{{{0.12F, 0.47F, 0.71F},
                                                       {1.00F, 0.50F, 0.05F},
                                                       {0.17F, 0.63F, 0.17F},
                                                       {0.84F, 0.15F, 0.16F},
                                                       {0.58F, 0.40F, 0.74F},
                                                       {0.55F, 0.34F, 0.29F},
                                                       {0.89F, 0.47F, 0.76F},
                                                       {0.50F, 0.50F, 0.50F},
                                                       {0.74F, 0.74F, 0.13F},
                                                       {0.09F, 0.75F, 0.81F}}};
  overlay::LayerStyle& style = description_->layers[sceneLayer].style;
  style.colorAttribute = attribute;
  style.categories.clear();
  std::size_t k = 0;
  for (const std::string& value : values) {
    const float shade = 1.0F - 0.3F * static_cast<float>(k / kPalette.size());
    style.categories[value] = glm::vec4(kPalette[k % kPalette.size()] * shade, 1.0F);
    ++k;
  }
  return true;
}

void Viewer::openTable(std::size_t sceneLayer) {
  if (featuresOf(sceneLayer) == nullptr) {
    message("the layer '" + description_->layers[sceneLayer].name + "' is not built: no table", true);
    return;
  }
  table_ = AttributeTable{};
  table_->sceneLayer = sceneLayer;
  table_->columns = attributeNames(sceneLayer);
  table_->dirty = true;
}

void Viewer::refreshTableRows() {
  AttributeTable& t = *table_;
  const std::vector<geo::Feature>& features = *featuresOf(t.sceneLayer);
  const std::string needle = lowerCase(t.search.data());
  const std::set<std::size_t> lassoed = selectedFeatureSet(t.sceneLayer);
  t.rows.clear();
  for (std::size_t f = 0; f < features.size(); ++f) {
    if (t.onlySelected && !lassoed.contains(f) && !t.selectedRows.contains(f)) continue;
    bool found = needle.empty();
    for (std::size_t c = 0; !found && c < t.columns.size(); ++c) {
      if (t.searchColumn >= 0 && static_cast<std::size_t>(t.searchColumn) != c) continue;
      const auto v = features[f].attributes.find(t.columns[c]);
      found =
          v != features[f].attributes.end() && lowerCase(attributeText(v->second)).find(needle) != std::string::npos;
    }
    if (!found && needle.size() > 0 && t.searchColumn < 0) found = std::to_string(features[f].fid).find(needle) == 0;
    if (found) t.rows.push_back(f);
  }
  if (t.sortColumn >= 0) {
    const auto column = static_cast<std::size_t>(t.sortColumn);
    std::stable_sort(t.rows.begin(), t.rows.end(), [&](std::size_t a, std::size_t b) {
      int order = 0;
      if (column == 0) {
        order = features[a].fid < features[b].fid ? -1 : (features[b].fid < features[a].fid ? 1 : 0);
      } else {
        const std::string& key = t.columns[column - 1];
        const auto va = features[a].attributes.find(key), vb = features[b].attributes.find(key);
        order = compareValues(va == features[a].attributes.end() ? geo::AttributeValue{} : va->second,
                              vb == features[b].attributes.end() ? geo::AttributeValue{} : vb->second);
      }
      return t.sortAscending ? order < 0 : order > 0;
    });
  }
  t.dirty = false;
}

std::set<std::size_t> Viewer::selectedFeatureSet(std::size_t sceneLayer) const {
  std::set<std::size_t> out;
  if (!selected_) return out;
  for (const scene::SelectedFeatures::Layer& l : selected_->layers) {
    if (l.sceneLayer != sceneLayer) continue;
    for (const overlay::FeatureSelection& f : l.features) out.insert(f.feature);
  }
  return out;
}

void Viewer::drawAttributeTable() {
  if (!table_) return;
  AttributeTable& t = *table_;
  if (featuresOf(t.sceneLayer) == nullptr) {
    table_.reset();
    return;
  }
  const std::vector<geo::Feature>& features = *featuresOf(t.sceneLayer);
  const ImGuiViewport* viewport = ImGui::GetMainViewport();
  const glm::dvec4 free = freeRegion();
  const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
  ImGui::SetNextWindowPos(ImVec2(viewport->WorkPos.x + static_cast<float>(free.x) / scale.x + 10.0F,
                                 viewport->WorkPos.y + viewport->WorkSize.y * 0.55F),
                          ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(
      ImVec2(std::max(viewport->WorkSize.x - static_cast<float>(free.x) / scale.x - 140.0F, 300.0F),
             viewport->WorkSize.y * 0.4F - ImGui::GetFrameHeight()),
      ImGuiCond_FirstUseEver);
  bool open = true;
  const std::string title = "Attributes: " + description_->layers[t.sceneLayer].name + "###attributes";
  if (!ImGui::Begin(title.c_str(), &open)) {
    ImGui::End();
    if (!open) table_.reset();
    return;
  }
  rememberWindow("table");
  // Search: all columns or one.
  ImGui::SetNextItemWidth(12.0F * ImGui::GetFontSize());
  if (ImGui::InputTextWithHint("##search", "search", t.search.data(), t.search.size())) t.dirty = true;
  rememberRect("table_search");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(9.0F * ImGui::GetFontSize());
  const char* in = t.searchColumn < 0 ? "in every column" : t.columns[static_cast<std::size_t>(t.searchColumn)].c_str();
  if (ImGui::BeginCombo("##in", in)) {
    if (ImGui::Selectable("in every column", t.searchColumn < 0)) {
      t.searchColumn = -1;
      t.dirty = true;
    }
    for (std::size_t c = 0; c < t.columns.size(); ++c) {
      if (ImGui::Selectable(t.columns[c].c_str(), t.searchColumn == static_cast<int>(c))) {
        t.searchColumn = static_cast<int>(c);
        t.dirty = true;
      }
    }
    ImGui::EndCombo();
  }
  ImGui::SameLine();
  if (ImGui::Checkbox("only selected", &t.onlySelected)) t.dirty = true;
  ImGui::SameLine();
  ImGui::BeginDisabled(t.selectedRows.empty());
  if (ImGui::Button("zoom to rows")) {
    zoomToFeatures(t.sceneLayer, std::vector<std::size_t>(t.selectedRows.begin(), t.selectedRows.end()));
  }
  ImGui::SameLine();
  if (ImGui::Button("clear rows")) t.selectedRows.clear();
  ImGui::EndDisabled();
  ImGui::SameLine();
  if (ImGui::Button("zoom to layer")) zoomToLayer(t.sceneLayer);
  if (t.dirty) refreshTableRows();
  ImGui::TextDisabled("%zu of %zu features; click a row to select it (Ctrl: add), double-click to zoom", t.rows.size(),
                      features.size());

  const std::set<std::size_t> lassoed = selectedFeatureSet(t.sceneLayer);
  const int columns = static_cast<int>(t.columns.size()) + 1;
  const ImGuiTableFlags flags = ImGuiTableFlags_Sortable | ImGuiTableFlags_Resizable | ImGuiTableFlags_ScrollX |
                                ImGuiTableFlags_ScrollY | ImGuiTableFlags_RowBg | ImGuiTableFlags_BordersV |
                                ImGuiTableFlags_Reorderable;
  if (columns <= 64 && ImGui::BeginTable("rows", columns, flags)) {
    ImGui::TableSetupScrollFreeze(1, 1);
    ImGui::TableSetupColumn("fid", ImGuiTableColumnFlags_DefaultSort);
    for (const std::string& c : t.columns) ImGui::TableSetupColumn(c.c_str());
    ImGui::TableHeadersRow();
    if (t.showSort) {
      // A sort asked for elsewhere (a script): the headers show it too.
      ImGui::TableSetColumnSortDirection(
          t.sortColumn, t.sortAscending ? ImGuiSortDirection_Ascending : ImGuiSortDirection_Descending, false);
      t.showSort = false;
    }
    if (ImGuiTableSortSpecs* sort = ImGui::TableGetSortSpecs(); sort != nullptr && sort->SpecsDirty) {
      if (sort->SpecsCount > 0) {
        t.sortColumn = sort->Specs[0].ColumnIndex;
        t.sortAscending = sort->Specs[0].SortDirection != ImGuiSortDirection_Descending;
      }
      sort->SpecsDirty = false;
      refreshTableRows();
    }
    ImGuiListClipper clipper;
    clipper.Begin(static_cast<int>(t.rows.size()));
    while (clipper.Step()) {
      for (int r = clipper.DisplayStart; r < clipper.DisplayEnd; ++r) {
        const std::size_t f = t.rows[static_cast<std::size_t>(r)];
        ImGui::TableNextRow();
        ImGui::TableNextColumn();
        const bool picked = t.selectedRows.contains(f);
        // Rows the lasso selected are marked, so the map and the table say the same.
        if (lassoed.contains(f)) ImGui::TableSetBgColor(ImGuiTableBgTarget_RowBg1, IM_COL32(200, 60, 40, 70));
        ImGui::PushID(static_cast<int>(f));
        if (ImGui::Selectable(std::to_string(features[f].fid).c_str(), picked,
                              ImGuiSelectableFlags_SpanAllColumns | ImGuiSelectableFlags_AllowDoubleClick)) {
          if (ImGui::GetIO().KeyCtrl) {
            if (picked) {
              t.selectedRows.erase(f);
            } else {
              t.selectedRows.insert(f);
            }
          } else {
            t.selectedRows = {f};
          }
          if (ImGui::IsMouseDoubleClicked(ImGuiMouseButton_Left)) zoomToFeatures(t.sceneLayer, {f});
        }
        ImGui::PopID();
        for (const std::string& c : t.columns) {
          ImGui::TableNextColumn();
          const auto v = features[f].attributes.find(c);
          if (v != features[f].attributes.end()) ImGui::TextUnformatted(attributeText(v->second).c_str());
        }
      }
    }
    ImGui::EndTable();
  } else if (columns > 64) {
    ImGui::TextWrapped("%d attributes: more than the table shows (64)", columns - 1);
  }
  ImGui::End();
  if (!open) table_.reset();
}

void Viewer::drawLegend() {
  if (!showLegend_) return;
  const ImGuiViewport* viewport = ImGui::GetMainViewport();
  const glm::dvec4 free = freeRegion();
  const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
  ImGui::SetNextWindowPos(
      ImVec2(viewport->WorkPos.x + static_cast<float>(free.x) / scale.x + 10.0F, viewport->WorkPos.y + 10.0F),
      ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowBgAlpha(0.75F);
  if (!ImGui::Begin("Legend", &showLegend_, ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoFocusOnAppearing)) {
    ImGui::End();
    return;
  }
  rememberWindow("legend");
  const float box = ImGui::GetTextLineHeight();
  const auto swatch = [&](const glm::vec4& fill, float opacity, const std::optional<glm::vec4>& outline, bool line) {
    const ImVec2 p = ImGui::GetCursorScreenPos();
    ImDrawList* draw = ImGui::GetWindowDrawList();
    const ImU32 colour = ImGui::ColorConvertFloat4ToU32(ImVec4(fill.x, fill.y, fill.z, opacity * fill.w));
    if (line) {
      draw->AddLine(ImVec2(p.x, p.y + box * 0.5F), ImVec2(p.x + box * 1.6F, p.y + box * 0.5F), colour, box * 0.35F);
    } else {
      draw->AddRectFilled(p, ImVec2(p.x + box * 1.6F, p.y + box), colour);
      if (outline) {
        draw->AddRect(p, ImVec2(p.x + box * 1.6F, p.y + box),
                      ImGui::ColorConvertFloat4ToU32(ImVec4(outline->x, outline->y, outline->z, outline->w)), 0.0F, 0,
                      2.0F);
      }
    }
    ImGui::Dummy(ImVec2(box * 1.6F, box));
    ImGui::SameLine();
  };
  std::size_t shown = 0;
  for (std::size_t i = 0; i < description_->layers.size(); ++i) {
    if (!sceneLayerShown(i)) continue;
    ++shown;
    const scene::LayerDescription& layer = description_->layers[i];
    const overlay::LayerStyle& s = layer.style;
    const bool line = layer.kind == overlay::LayerKind::Line;
    const bool outlined = s.outlineWidthMetres > 0.0F || s.outlineWidthPixels > 0.0F;
    const std::optional<glm::vec4> outline = outlined ? std::optional<glm::vec4>(s.outlineColor) : std::nullopt;
    swatch(s.color, s.opacity, outline, line);
    ImGui::TextUnformatted(layer.name.c_str());
    if (!s.colorAttribute.empty()) {
      ImGui::Indent();
      ImGui::TextDisabled("by %s", s.colorAttribute.c_str());
      for (const auto& [value, colour] : s.categories) {
        swatch(colour, s.opacity, outline, line);
        ImGui::TextUnformatted(value.empty() ? "(empty)" : value.c_str());
      }
      swatch(s.color, s.opacity, outline, line);
      ImGui::TextDisabled("other");
      ImGui::Unindent();
    }
  }
  if (shown == 0) ImGui::TextDisabled("no layer shown");
  drawElevationLegend();
  ImGui::End();
}

const std::vector<float>& Viewer::frameDepth() {
  // Read once per frame, by whatever draws on the ground first.
  if (depthFrame_ != frameIndex_) {
    frameDepth_ = gfx::readDepth(*target_);
    depthFrame_ = frameIndex_;
  }
  return frameDepth_;
}

glm::dmat4 Viewer::screenViewProj() const {
  if (globe_) return globe_->view.viewProj();
  const scene::Camera c = camera();
  return c.projection(aspect()) * c.view();
}

void Viewer::drawLifted(const std::vector<glm::dvec3>& path, ImU32 colour, float width) {
  // Hidden parts (behind a hill) are left out: a point shows when it is no farther than the
  // surface drawn at its pixel (or a neighbour), within half a percent.
  const std::vector<float>& depth = frameDepth();
  const int w = target_->width(), h = target_->height();
  const glm::dmat4 viewProj = screenViewProj();
  const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
  const auto visible = [&](const glm::dvec3& pixel) {
    const int x = static_cast<int>(std::floor(pixel.x)), y = static_cast<int>(std::floor(pixel.y));
    float farthest = std::numeric_limits<float>::infinity();
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const int px = std::clamp(x + dx, 0, w - 1), py = std::clamp(y + dy, 0, h - 1);
        farthest = std::min(
            farthest, depth[static_cast<std::size_t>(py) * static_cast<std::size_t>(w) + static_cast<std::size_t>(px)]);
      }
    }
    return pixel.z >= static_cast<double>(farthest) / 1.005;
  };
  ImDrawList* draw = ImGui::GetBackgroundDrawList();
  std::vector<ImVec2> run;
  const auto flush = [&] {
    if (run.size() >= 2) draw->AddPolyline(run.data(), static_cast<int>(run.size()), colour, 0, width);
    run.clear();
  };
  for (const glm::dvec3& p : path) {
    const glm::dvec4 clip = viewProj * glm::dvec4(p, 1.0);
    if (!(clip.w > 0.0) || !std::isfinite(p.z)) {
      flush();
      continue;
    }
    const glm::dvec3 ndc = glm::dvec3(clip) / clip.w;
    const glm::dvec3 pixel((ndc.x * 0.5 + 0.5) * w, (0.5 - ndc.y * 0.5) * h, ndc.z);
    if (pixel.x < -w || pixel.x > 2.0 * w || pixel.y < -h || pixel.y > 2.0 * h) {
      flush();
      continue;
    }
    const bool inside = pixel.x >= 0.0 && pixel.x < w && pixel.y >= 0.0 && pixel.y < h;
    if (inside && !visible(pixel)) {
      flush();
      continue;
    }
    run.emplace_back(static_cast<float>(pixel.x) / scale.x, static_cast<float>(pixel.y) / scale.y);
  }
  flush();
}

std::vector<glm::dvec3> Viewer::liftPath(const std::vector<glm::dvec2>& points, bool closed) const {
  return scene_->groundPath(points, closed);
}

void Viewer::drawGroundPath(const std::vector<glm::dvec2>& points, ImU32 colour, float width) {
  if (!target_ || points.size() < 2) return;
  drawLifted(liftPath(points, false), colour, width);
}

std::vector<std::vector<glm::dvec3>> Viewer::liftedBoundary(const geo::Feature& feature) const {
  std::vector<std::vector<glm::dvec3>> paths;
  for (const geo::Polygon& p : feature.polygons) {
    paths.push_back(liftPath(p.outer, true));
    for (const geo::Ring& h : p.holes) paths.push_back(liftPath(h, true));
  }
  for (const geo::LineString& l : feature.lines) paths.push_back(liftPath(l, false));
  return paths;
}

void Viewer::drawOutline(const std::vector<std::vector<glm::dvec3>>& paths, ImU32 colour) {
  // As wide as the feature is large on screen allows: 2.5 px for a feature some 30 px across,
  // thinner below, none under 3 px (the selection's highlight shows it). From afar, the outlines
  // of many small selected features then stay apart instead of merging into one blob.
  const glm::dmat4 viewProj = screenViewProj();
  const glm::dvec2 size(target_->width(), target_->height());
  glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (const std::vector<glm::dvec3>& path : paths) {
    for (const glm::dvec3& p : path) {
      const glm::dvec4 clip = viewProj * glm::dvec4(p, 1.0);
      if (!(clip.w > 0.0)) continue;
      const glm::dvec2 pixel((clip.x / clip.w * 0.5 + 0.5) * size.x, (0.5 - clip.y / clip.w * 0.5) * size.y);
      lo = glm::min(lo, pixel);
      hi = glm::max(hi, pixel);
    }
  }
  const float width = outlineWidthFor(hi.x >= lo.x ? glm::length(hi - lo) : 0.0);
  if (width <= 0.0F) return;
  for (const std::vector<glm::dvec3>& path : paths) drawLifted(path, colour, width);
}

void Viewer::drawHighlights() {
  // The identified features in cyan, the lasso's and the table's in the highlight colour, each
  // outline as wide as the feature is large on screen, its rings on the ground as drawn (along
  // geodesics on the globe), kept per scene layer and feature.
  std::set<std::pair<std::size_t, std::size_t>> features, identified;
  if (identified_) {
    for (const Identified::Hit& hit : identified_->hits) {
      for (std::size_t i = 0; i < description_->layers.size(); ++i) {
        if (description_->layers[i].name != hit.layer) continue;
        features.emplace(i, hit.feature);
        identified.emplace(i, hit.feature);
      }
    }
  }
  if (selected_) {
    for (const scene::SelectedFeatures::Layer& l : selected_->layers) {
      for (const overlay::FeatureSelection& f : l.features) features.emplace(l.sceneLayer, f.feature);
    }
  }
  if (table_) {
    for (const std::size_t f : table_->selectedRows) features.emplace(table_->sceneLayer, f);
  }
  highlightedCount_ = features.size();
  if (features.empty() || !target_) return;
  if (outlinesExaggeration_ != exaggeration()) {
    outlines_.clear();  // lifted at another exaggeration
    outlinesExaggeration_ = exaggeration();
  }
  const ImU32 identifiedColour = IM_COL32(40, 230, 255, 255);
  const ImU32 selectedColour =
      ImGui::ColorConvertFloat4ToU32(ImVec4(highlight_.color.x, highlight_.color.y, highlight_.color.z, 1.0F));
  for (const auto& f : features) {
    auto cached = outlines_.find(f);
    if (cached == outlines_.end()) {
      const std::shared_ptr<const geo::Feature> feature = featureAt(f.first, f.second);
      cached = outlines_.emplace(f, feature ? liftedBoundary(*feature) : std::vector<std::vector<glm::dvec3>>()).first;
    }
    drawOutline(cached->second, identified.contains(f) ? identifiedColour : selectedColour);
  }
}

}  // namespace gis::viewer
