// The open-file dialog (Ctrl+O): a small file browser in the panel's toolkit. Debian ships no
// native dialog for Dear ImGui, and a desktop's own (zenity, kdialog) is not always there; this
// one works on any display, with the keyboard alone (type a path, Enter) or the mouse.
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>

#include "gfx/gl.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>

#include "viewer.hpp"

namespace gis::viewer {
namespace {

namespace fs = std::filesystem;

std::string lowerExtension(const fs::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return e;
}

/// What the viewer opens: scene files, DEMs and vector files.
bool openable(const fs::path& p) {
  static const char* const kExtensions[] = {".json",    ".tif", ".tiff", ".asc", ".img", ".vrt", ".hgt", ".dem", ".bil",
                                            ".geojson", ".shp", ".gpkg", ".kml", ".gml", ".csv", ".fgb", ".gpx"};
  const std::string e = lowerExtension(p);
  return std::any_of(std::begin(kExtensions), std::end(kExtensions), [&](const char* x) { return e == x; });
}

}  // namespace

void Viewer::openFileBrowser() {
  FileBrowser& b = browser_;
  b.open = true;
  b.focusPath = true;
  if (b.directory.empty()) {
    std::error_code ec;
    // Where the scene came from, else the working directory.
    fs::path start = description_ ? fs::path(description_->path).parent_path() : fs::current_path(ec);
    if (start.empty() || !fs::is_directory(start, ec)) start = fs::current_path(ec);
    browseTo(start);
  } else {
    browseTo(b.directory);
  }
}

void Viewer::browseTo(const std::filesystem::path& directory) {
  FileBrowser& b = browser_;
  std::error_code ec;
  const fs::path dir = fs::weakly_canonical(directory, ec);
  b.entries.clear();
  b.error.clear();
  fs::directory_iterator it(dir, fs::directory_options::skip_permission_denied, ec);
  if (ec) {
    b.error = dir.string() + ": " + ec.message();
    return;
  }
  b.directory = dir;
  for (; it != fs::directory_iterator(); it.increment(ec)) {
    if (ec) break;
    const fs::path p = it->path();
    if (p.filename().string().rfind('.', 0) == 0) continue;  // hidden
    const bool isDir = it->is_directory(ec);
    if (isDir || openable(p)) b.entries.push_back({p.filename().string(), isDir});
  }
  std::sort(b.entries.begin(), b.entries.end(), [](const FileBrowser::Entry& a, const FileBrowser::Entry& c) {
    return a.directory != c.directory ? a.directory : a.name < c.name;
  });
  std::snprintf(b.path.data(), b.path.size(), "%s", (dir.string() + "/").c_str());
}

void Viewer::openFromBrowser(const std::filesystem::path& path) {
  std::error_code ec;
  // A folder of DEM tiles opens as one DEM; any other folder is browsed into.
  if (fs::is_directory(path, ec)) {
    // Tiles: rasters and no scene file beside them.
    bool rasters = false, scenes = false;
    for (const fs::directory_entry& e : fs::directory_iterator(path, ec)) {
      const std::string x = lowerExtension(e.path());
      rasters = rasters || x == ".tif" || x == ".tiff" || x == ".hgt";
      scenes = scenes || x == ".json";
    }
    if (!rasters || scenes) {
      browseTo(path);
      return;
    }
  } else if (!fs::exists(path, ec)) {
    browser_.error = path.string() + ": no such file";
    return;
  }
  browser_.open = false;
  dropped_.push_back(path.string());  // opened at the next frame, as a dropped file
}

void Viewer::drawFileBrowser() {
  FileBrowser& b = browser_;
  if (!b.open) return;
  const ImGuiViewport* viewport = ImGui::GetMainViewport();
  ImGui::SetNextWindowPos(viewport->GetCenter(), ImGuiCond_Appearing, ImVec2(0.5F, 0.5F));
  ImGui::SetNextWindowSize(ImVec2(std::min(40.0F * ImGui::GetFontSize(), viewport->WorkSize.x * 0.9F),
                                  std::min(28.0F * ImGui::GetFontSize(), viewport->WorkSize.y * 0.8F)),
                           ImGuiCond_Appearing);
  if (!ImGui::Begin("Open a scene, DEM or vector file", &b.open, ImGuiWindowFlags_NoCollapse)) {
    ImGui::End();
    return;
  }
  ImGui::TextWrapped("Scenes (.json) and DEMs replace the scene; vector files are added to it as layers.");
  if (ImGui::Button("Up")) browseTo(b.directory.parent_path());
  ImGui::SameLine();
  ImGui::SetNextItemWidth(-4.0F * ImGui::GetFontSize());
  if (b.focusPath) {
    ImGui::SetKeyboardFocusHere();
    b.focusPath = false;
  }
  const bool enter = ImGui::InputText("##path", b.path.data(), b.path.size(), ImGuiInputTextFlags_EnterReturnsTrue);
  rememberRect("open_path");
  ImGui::SameLine();
  if (ImGui::Button("Open") || enter) openFromBrowser(fs::path(b.path.data()));
  if (!b.error.empty()) ImGui::TextColored(ImVec4(1.0F, 0.45F, 0.4F, 1.0F), "%s", b.error.c_str());
  ImGui::Separator();
  ImGui::BeginChild("entries");
  for (const FileBrowser::Entry& e : b.entries) {
    const std::string label = e.directory ? e.name + "/" : e.name;
    if (ImGui::Selectable(label.c_str(), false, ImGuiSelectableFlags_AllowDoubleClick)) {
      const fs::path p = b.directory / e.name;
      std::snprintf(b.path.data(), b.path.size(), "%s", p.string().c_str());
      if (ImGui::IsMouseDoubleClicked(ImGuiMouseButton_Left)) {
        if (e.directory) {
          browseTo(p);
        } else {
          openFromBrowser(p);
        }
        break;  // the entries changed
      }
    }
  }
  if (b.entries.empty()) ImGui::TextDisabled("nothing to open here");
  ImGui::EndChild();
  ImGui::End();
}

}  // namespace gis::viewer
