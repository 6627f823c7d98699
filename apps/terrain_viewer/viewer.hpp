#pragma once
// The desktop viewer (docs/design.md §8, issue 6): a scene in a GLFW window, flown with the camera
// controller, the vector layers drawn exactly with stencil polyhedra, a Dear ImGui panel, the
// lasso tool, identify, HUD, screenshots, and a scripted mode that drives all of it for tests
// under Xvfb. The scene is drawn into an offscreen target (float depth with stencil: reversed-Z
// needs it, and identify and screenshots read it back), then copied to the window; the panel is
// drawn over the copy.
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <future>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include <imgui.h>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <nlohmann/json_fwd.hpp>

#include "app/labels.hpp"
#include "app/viewer_script.hpp"
#include "app/viewer_settings.hpp"
#include "gfx/context.hpp"
#include "gfx/render_target.hpp"
#include "gfx/state_cache.hpp"
#include "scene/camera_controller.hpp"
#include "scene/frame_renderer.hpp"
#include "scene/frame_scene.hpp"
#include "scene/globe_camera.hpp"
#include "scene/globe_scene.hpp"
#include "scene/globe_selection.hpp"
#include "scene/measure.hpp"
#include "scene/scene_loader.hpp"
#include "scene/scene_renderer.hpp"
#include "scene/scene_selection.hpp"
#include "scene/selected_features.hpp"
#include "vector_overlay/selection_renderer.hpp"

namespace gis::viewer {

struct ViewerOptions {
  std::string scene;
  std::optional<std::string> script;  ///< scripted run: settings neither read nor written
};

/// A point drawn at a pixel, in either frame, in the coordinates a person reads: heights are true
/// (above the DEM's datum, or on the globe the ellipsoid), never exaggerated.
struct GroundPoint {
  glm::dvec3 drawn{0.0};  ///< as drawn: frame coordinates (z exaggerated), or ECEF on the globe
  /// The DEM's (scene's) CRS: easting, northing, height (a projected scene).
  std::optional<glm::dvec3> projected;
  std::optional<glm::dvec3> lonLatH;  ///< degrees on the CRS's datum (on the globe WGS 84), and the height
  double height = 0.0;
  bool onGlobe = false;
};

/// What is under a pixel: the terrain point and every feature of a shown layer that covers it.
struct Identified {
  GroundPoint point;
  double terrainHeight = 0.0;  ///< the DEM's height there (full resolution), true
  struct Hit {
    std::string layer;
    std::size_t feature = 0;
    std::int64_t fid = -1;
    std::vector<std::pair<std::string, std::string>> attributes;
  };
  std::vector<Hit> hits;
  [[nodiscard]] nlohmann::json toJson() const;
};

/// A ground point as the state and identify write it.
nlohmann::json groundPointJson(const GroundPoint& point);

/// A window event as GLFW reported it. Events are queued in order by GLFW's callbacks and taken
/// a frame at a time (Viewer::takeInput), so none is lost at any frame rate.
struct InputEvent {
  enum class Kind : std::uint8_t { Cursor, Button, Key, Char, Scroll };
  Kind kind = Kind::Cursor;
  glm::dvec2 value{0.0};  ///< Cursor: window coordinates; Scroll: offsets
  int code = 0;           ///< Button: GLFW button; Key: GLFW key; Char: code point
  int scancode = 0;
  int action = 0;  ///< GLFW_PRESS, GLFW_RELEASE or GLFW_REPEAT
  int mods = 0;
};

/// One frame's mouse and keyboard: taken from the window's event queue, or played from a script
/// (the same handling).
struct InputFrame {
  glm::dvec2 cursor{0.0};  ///< framebuffer pixels, origin top-left
  /// Every cursor position taken in this frame, in order (the last is `cursor`): a lasso drawn
  /// faster than the frames keeps its shape.
  std::vector<glm::dvec2> cursorPath;
  bool left = false, right = false, middle = false;
  app::Modifiers modifiers;
  double scroll = 0.0;    ///< wheel steps since the last frame, positive zooms in
  std::vector<int> held;  ///< GLFW keys held down (fly: W A S D Q E)
  /// A key pressed, with the modifiers held when it was (Ctrl+Z: Ctrl may be up by the end of
  /// the frame).
  struct KeyPress {
    int key = 0;
    app::Modifiers modifiers;
  };
  std::vector<KeyPress> pressed;  ///< since the last frame (edge-triggered actions)
  bool uiMouse = false;           ///< the panel takes the mouse
  bool uiKeyboard = false;        ///< the panel takes the keyboard
};

/// "lon −34.854321°, lat −8.012345°": the order and labels used everywhere in the viewer.
std::string formatLonLat(const glm::dvec3& lonLatH);
/// A length for a person: "12.50 m", "350 m", "12.5 km".
std::string formatMetres(double metres);
/// An area for a person: "850 m²", "12.5 ha", "3.20 km²".
std::string formatArea(double squareMetres);
/// The width (pixels) of a highlighted feature's outline that spans `acrossPixels` on screen (the
/// diagonal of its extent there): 2.5 from 30 px, thinner below (at least 1), none under 3 px.
float outlineWidthFor(double acrossPixels);
/// The largest 1, 2 or 5 × 10^k not above `most` (a scale bar's length); 0 for none.
double niceLength(double most);
/// A window listing keys and what they do (the help, ?), centred when it appears.
void drawKeysWindow(const char* title, bool* open, std::span<const std::array<const char*, 2>> rows);

/// A scene being read on a worker thread, in the frame scene::globeReason chooses (scene::Scene).
struct PendingLoad {
  std::future<Result<scene::Scene>> job;
  [[nodiscard]] bool ready() const {
    return job.valid() && job.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
  }
  void wait() const {
    if (job.valid()) job.wait();
  }
  scene::SceneDescription description;
  std::shared_ptr<std::atomic<double>> progress;  ///< a tile pyramid's build, 0…1; negative: none reported
  double started = 0.0;                           ///< glfwGetTime
  std::string label;
};

/// The lasso operator the modifiers choose (docs/viewer.md): Shift Or, Ctrl Subtract, Ctrl+Shift
/// And, Alt Xor; none: Single.
overlay::SelectionOp lassoOpOf(const app::Modifiers& m);

/// An attribute's value as a person reads it ("" for none).
std::string attributeText(const geo::AttributeValue& value);

/// The attribute table of one layer (viewer_attributes.cpp).
struct AttributeTable {
  std::size_t sceneLayer = 0;
  std::vector<std::string> columns;  ///< every attribute name of the layer (after fid)
  std::array<char, 128> search{};
  int searchColumn = -1;  ///< -1: every column
  bool onlySelected = false;
  int sortColumn = 0;  ///< 0: fid, c: columns[c - 1]
  bool sortAscending = true;
  bool showSort = false;          ///< the sort was set outside the table's headers: show it there
  std::vector<std::size_t> rows;  ///< features shown, in order
  std::set<std::size_t> selectedRows;
  bool dirty = true;  ///< rows to recompute
};

/// Metres in a degree of latitude (and of longitude at the equator), near enough for sampling
/// steps and local planes on the globe.
inline constexpr double kMetresPerDegree = 111'320.0;

/// One layer's labels: the attribute, each feature's text and ground anchor, the anchors' heights.
/// On the globe the anchors are (lon, lat) degrees and the heights above the ellipsoid.
struct LabelSet {
  std::string attribute;
  std::vector<app::FeatureLabel> labels;
  std::vector<double> heights;  ///< as drawn, at `exaggeration`
  double exaggeration = 0.0;    ///< 0: heights not looked up yet
};

/// The globe's navigation (docs/viewer.md "On the globe"): its camera controller, the view it
/// gave the last frame, and fly mode. The scene and its renderer are the
/// viewer's, as in a projected frame; the projected camera controller is empty while it is shown.
struct GlobeMode {
  std::unique_ptr<scene::GlobeCameraController> controller;  ///< reads the scene's heights
  globe::GlobeView view;                                     ///< the last frame's
  bool fly = false;  ///< fly mode (F): WASD/QE move the eye, drags turn the view about it
};

/// The open-file dialog's state (viewer_file_browser.cpp).
struct FileBrowser {
  struct Entry {
    std::string name;
    bool directory = false;
  };
  bool open = false;
  bool focusPath = false;  ///< the path field takes the keyboard when the dialog opens
  std::filesystem::path directory;
  std::vector<Entry> entries;  ///< folders first, then the files the viewer opens
  std::array<char, 1024> path{};
  std::string error;
};

class Viewer {
 public:
  /// Opens the window and runs until it is closed (or the script ends). Returns the exit status:
  /// 0, or 1 when the scene or the window could not be opened, a script step failed, or GL
  /// reported an error during a scripted run.
  static int run(const ViewerOptions& options);

  ~Viewer();
  Viewer(const Viewer&) = delete;
  Viewer& operator=(const Viewer&) = delete;

 private:
  Viewer() = default;
  bool open(const ViewerOptions& options);
  /// Loads a scene file (or makes a scene of a DEM, or adds a vector layer to the current
  /// scene) — what dropping a file on the window does. Reports and keeps the old scene on failure.
  bool loadPath(const std::string& path);
  /// Starts reading the scene on a worker (finishLoad takes it when done).
  bool useScene(scene::SceneDescription description);
  /// The scene read in the background, made current (renderer, home view) when it is ready;
  /// `wait`: waits for it.
  void finishLoad(bool wait);
  /// The progress of a load that takes more than a moment.
  void drawLoading();
  void frame(double seconds);
  /// The part of the window the panel and the status bar leave free, framebuffer pixels
  /// (x0, y0, x1, y1 from the top left).
  [[nodiscard]] glm::dvec4 freeRegion() const;
  /// The home view: the scene's camera, or the terrain framed in the free region.
  [[nodiscard]] scene::Camera homeCamera() const;
  void goHome();

  // Input (viewer_input.cpp).
  /// Sends the window's events to this viewer's queue.
  void installCallbacks();
  /// This frame's input from the queue, and the same events passed to the panel (ImGui). A
  /// frame takes events in order until one would change a button or key a second time (a
  /// click shorter than a frame is a press frame and a release frame); a button event is a
  /// frame of its own, so the frame sees the cursor and modifiers it came with (releasing Shift
  /// just after the mouse button keeps an Or lasso); a modifier's change after another key's
  /// starts the next frame (Ctrl+A released at once still selects all in a text field). Keys
  /// of printable characters typed into a text field do not hold a frame each (their text
  /// comes as characters, in order).
  [[nodiscard]] InputFrame takeInput();
  /// After ImGui's platform frame: the panel sees the queue's mouse, not the live one.
  void feedImGuiMouse() const;
  /// Whether the next frame must be drawn now: input to handle, motion, work arriving (tiles,
  /// a selection), a script. Otherwise the loop sleeps until an event.
  [[nodiscard]] bool needsFrame() const;
  /// How long the loop may sleep before the next frame: 0 to draw now, infinity until an event.
  [[nodiscard]] double idleWait() const;
  /// Woken from a sleep with nothing to draw: asks for a frame if work finished in the
  /// background (a scene read, a selection found), a notice expired or a live step's file came.
  void idleTick();
  [[nodiscard]] bool keyDown(int key) const {
    return key >= 0 && static_cast<std::size_t>(key) < keysDown_.size() && keysDown_[static_cast<std::size_t>(key)];
  }
  void handleInput(double seconds, const InputFrame& in);
  void handleMouse(const InputFrame& in);
  /// The camera's part of the mouse, in the frame's way (viewer_navigation.cpp): `pressed` the
  /// left button went down in this frame, `dragStarts` its drag began.
  void navigate(const InputFrame& in, bool pressed, bool dragStarts);
  /// Fly mode (F): W A S D and Q E move the eye, drags turn the view about it.
  [[nodiscard]] bool flying() const;
  void setFlying(bool fly);
  void flyBy(const glm::dvec3& move, double seconds);
  /// A camera key of the frame's own (the globe's arrows and Page Up / Down); false if not one.
  bool navigationKey(int key);
  /// A key pressed (edge-triggered): the viewer's key commands. `fly`: the camera mode when the
  /// frame's input began (F toggles from it).
  void keyPressed(int key, bool fly, const app::Modifiers& modifiers);
  /// The keys that do the same in a projected scene and on the globe (quit, the selection's
  /// invert, clear, undo and redo, overlays, panel, HUD, screenshot, help).
  void sharedKeyPressed(int key, const app::Modifiers& modifiers);
  /// The GLFW key of a script's key name (app::KeyStep::key), or GLFW_KEY_UNKNOWN.
  static int keyCode(const std::string& name);

  /// What a test of the viewer checks: camera and pose, window, selection, identify, layers.
  [[nodiscard]] nlohmann::json state() const;
  /// The frame's own keys of a scene layer's entry in state() (its feature counts).
  [[nodiscard]] nlohmann::json frameLayerJson(std::size_t sceneLayer) const;
  /// The frame's own keys of state(): its camera ("camera_mode", a projected "camera" and "pose",
  /// the globe's "globe") and what the last frame drew ("drawn").
  [[nodiscard]] nlohmann::json frameStateJson() const;
  /// The GLFW keys held down as the queue has them (a stuck key shows here).
  [[nodiscard]] nlohmann::json keysDownJson() const;
  [[nodiscard]] nlohmann::json measureJson() const;
  /// The attribute table as the state tells it (layer, rows, the first rows' fids, selected
  /// rows), in either frame; null when it is closed.
  [[nodiscard]] nlohmann::json tableJson() const;
  /// Mark and cover fragments of the overlay layers in the last measured frame.
  [[nodiscard]] std::uint64_t overlayFragments() const;
  /// The frame into the target and the window, in either frame: the terrain and layers through
  /// the scene's FrameRenderer, then the selection, the pieces' debug view and the copy.
  void drawScene();

  // The panel, a function per section (viewer_panel.cpp).
  void drawPanel();
  /// The last item's rectangle (window units) under `name`, for tests that click it.
  void rememberRect(const std::string& name);
  void drawViewSection();
  void drawOverlaySection();
  /// The drape's (or each tile's) texture size, for the draping methods.
  void drawDrapeSize();
  void drawLayersSection();
  /// Scene layer i's row and, when open, its style; true when the style changed (to rebuild).
  bool drawLayer(std::size_t i);
  void drawSelectionSection();
  /// The lasso tool, the operators' hint, Invert, Clear, the highlight's colour, undo and redo,
  /// and the chain of steps: the same in a projected scene and on the globe.
  void drawLassoControls();
  void drawSelectedFeatures();
  /// The export path's field (Enter exports) and the Export GeoJSON button: the same in a
  /// projected scene and on the globe.
  void drawExportControls();
  void drawMessagesSection();
  /// The scene's cache: where, its size (counted when shown, every few seconds), "Clear cache".
  void drawCacheSection();
  /// The window without a scene: what went wrong, and what to open.
  void drawNoScene();
  void drawHud();
  /// The HUD window (top right, see-through, no input) with the frame rate; End() is the caller's.
  void beginHud();
  void drawHelp();
  void drawIdentify();
  void drawLassoOutline();

  // Attributes, legend, highlights (viewer_attributes.cpp).
  /// The overlay layer holding a scene layer's features (its fill); none if it is not built.
  [[nodiscard]] std::optional<std::size_t> fillLayerOf(std::size_t sceneLayer) const;
  /// A scene layer's features as drawn, in either frame: a projected scene's fill layer's, the
  /// globe's source layer's (scene::LoadedLayer in both); none when the layer is not built.
  [[nodiscard]] const std::vector<geo::Feature>* featuresOf(std::size_t sceneLayer) const;
  /// Feature `feature` of scene layer `sceneLayer` alone (a globe layer's may be on disk); null
  /// when there is none.
  [[nodiscard]] std::shared_ptr<const geo::Feature> featureAt(std::size_t sceneLayer, std::size_t feature) const;
  /// The renderer's drawn layers (fill, then outline) of scene layer `sceneLayer`, in either frame.
  [[nodiscard]] std::vector<std::size_t> drawnLayersOf(std::size_t sceneLayer) const;
  /// The name of the scene layer a drawn layer draws (what identify's hits and the state name).
  [[nodiscard]] std::string sceneLayerNameOf(std::size_t drawn) const;
  [[nodiscard]] std::vector<std::string> attributeNames(std::size_t sceneLayer) const;
  /// Moves the camera (animated) to frame a box in the free part of the window, keeping the heading.
  void zoomToBox(glm::dvec3 lo, glm::dvec3 hi);
  /// Frames features of a scene layer (their box), in either frame.
  void zoomToFeatures(std::size_t sceneLayer, const std::vector<std::size_t>& features);
  void zoomToLayer(std::size_t sceneLayer);
  void openTable(std::size_t sceneLayer);
  /// Colours a layer by category of an attribute (a palette over its values); false when it has
  /// more than kMaxCategories values (said in the messages).
  bool setCategories(std::size_t sceneLayer, const std::string& attribute);
  static constexpr std::size_t kMaxCategories = 40;
  /// The layer's colour-by-category control; true when the style changed (to rebuild).
  bool drawCategories(std::size_t sceneLayer);
  /// The layer's label control: none, or an attribute.
  void drawLabelChoice(std::size_t sceneLayer);
  void refreshTableRows();
  /// The features of a scene layer the lasso selected, in either frame.
  [[nodiscard]] std::set<std::size_t> selectedFeatureSet(std::size_t sceneLayer) const;
  void drawAttributeTable();
  void drawLegend();
  /// The DEM's colour ramp in the legend, when the terrain is tinted by height.
  void drawElevationLegend();
  /// The identified, lasso-selected and table-selected features' own outlines over the scene,
  /// hidden parts left out (outlines_ keeps them per scene layer and feature).
  void drawHighlights();
  /// A feature's boundary (rings, or its lines) lifted onto the ground as drawn, in either frame.
  [[nodiscard]] std::vector<std::vector<glm::dvec3>> liftedBoundary(const geo::Feature& feature) const;
  /// Lifted paths drawn over the scene, as wide as the feature is large on screen (none under
  /// 3 px), hidden behind the terrain.
  void drawOutline(const std::vector<std::vector<glm::dvec3>>& paths, ImU32 colour);
  /// The last frame's depth (top row first), read once per frame.
  const std::vector<float>& frameDepth();
  /// Frame (or, on the globe, ECEF) coordinates → clip coordinates of the frame drawn.
  [[nodiscard]] glm::dmat4 screenViewProj() const;
  /// A path on the ground (frame points, heights as drawn; ECEF on the globe) over the scene: its
  /// visible parts.
  void drawLifted(const std::vector<glm::dvec3>& path, ImU32 colour, float width);
  /// Frame x/y points lifted onto the terrain as drawn, densified to follow the relief.
  [[nodiscard]] std::vector<glm::dvec3> liftPath(const std::vector<glm::dvec2>& points, bool closed) const;
  void drawGroundPath(const std::vector<glm::dvec2>& points, ImU32 colour, float width);

  // The open-file dialog (viewer_file_browser.cpp).
  void openFileBrowser();
  void browseTo(const std::filesystem::path& directory);
  /// A file opens (at the next frame, as if dropped); a folder is browsed into, unless it holds
  /// DEM tiles only (then it opens as one DEM).
  void openFromBrowser(const std::filesystem::path& path);
  void drawFileBrowser();

  // Measuring (viewer_measure.cpp).
  /// Measures along the ground points under these pixels (a ring when `closed`); false when a
  /// pixel shows no terrain.
  bool measureAtPixels(const std::vector<glm::dvec2>& pixels, bool closed);
  void addMeasurePoint(const glm::dvec2& frameXY);
  /// The measure point under a pixel: frame x/y, or lon/lat on the globe.
  [[nodiscard]] std::optional<glm::dvec2> measurePointAt(const glm::dvec2& pixel) const;
  /// A measure point on the ground as drawn: frame x/y/z, or ECEF on the globe.
  [[nodiscard]] glm::dvec3 measurePointPosition(const glm::dvec2& point) const;
  void clearMeasure();
  void remeasure();
  void drawMeasure();
  void drawMeasureSection();

  // Labels (viewer_labels.cpp).
  /// Labels a layer with an attribute's values ("" removes its labels).
  void setLabels(std::size_t sceneLayer, const std::string& attribute);
  void drawLabels();
  /// The current ImGui window's rectangle, which labels keep clear of in the next frame.
  void rememberWindow(const std::string& name);
  /// The windows as last drawn (rememberWindow): name → [x0, y0, x1, y1] in window points.
  [[nodiscard]] nlohmann::json windowsJson() const;

  // Map tools (viewer_map_tools.cpp).
  /// Coordinates under the cursor: lon/lat, the scene CRS's easting and northing, true height.
  void drawStatusBar();
  void drawScaleBar();
  /// North on screen; a click turns the view north-up.
  void drawCompass();
  /// A pixel's ground size at the view's centre (none when no terrain is there).
  [[nodiscard]] std::optional<double> metresPerPixelAtCentre() const;
  /// The heading (OrbitPose::yaw) that looks true north at the view's target.
  [[nodiscard]] std::optional<double> northYaw() const;
  void northUp();

  // Actions: the panel, the keys and the script call these.
  void setLayerShown(std::size_t sceneLayer, bool shown);
  /// Whether any overlay layer of a scene layer (fill or outline) is shown; none if the scene
  /// layer has no overlay layer (not built).
  [[nodiscard]] std::optional<bool> layerShown(std::size_t sceneLayer) const;
  /// Whether the scene file's layer `sceneLayer` is drawn now, in either frame (the legend's).
  [[nodiscard]] bool sceneLayerShown(std::size_t sceneLayer) const;
  void rebuildOverlays();
  /// After the layers were built again (styles, technique, exaggeration): what indexed them —
  /// identify's hits, outlines, the table's rows, the selection — is made again.
  void layersRebuilt();
  /// Draws with `technique` from now on (the panel's method buttons, a script's method step):
  /// a texture technique at `textureSize` texels a side, or (0) at the size in use where it offers
  /// it, else at its own default (a single drape's size would be far too much per tile).
  void useTechnique(const overlay::TechniqueInfo& technique, int textureSize = 0);
  void addLasso(overlay::SelectionOp op, std::vector<glm::dvec2> points);
  /// Before a change of the selection's steps: the steps as they were, for undo.
  void rememberSelection();
  /// Ctrl+Z and Ctrl+Y (Ctrl+Shift+Z): a step of the selection's history back or forward.
  void undoSelection();
  void redoSelection();
  void invertSelection();
  void clearSelection();
  /// The vertical exaggeration, in either frame: the projected scene's height bounds own it, the
  /// globe's heights (GeoGrid::exaggerated).
  void setExaggeration(double exaggeration);
  [[nodiscard]] double exaggeration() const;
  /// The panel's exaggeration slider (both frames): applied at release.
  void drawExaggerationSlider();
  void selectionChanged();
  void startSelection();
  /// Takes the logical selection when its job is done (`wait`: waits for it).
  void pollSelection(bool wait);
  /// Waits for the selection job: before anything changes what it reads, and where its result is needed.
  void finishSelection();
  std::optional<Identified> identify(const glm::dvec2& pixel);
  /// Depth of the last frame at pixel (x, y), top-left origin; none where nothing was drawn.
  [[nodiscard]] std::optional<float> depthAt(int x, int y) const;
  /// The camera of the frame shown: a projected camera, or the globe's view.
  [[nodiscard]] scene::FrameCamera frameCamera() const;
  /// The point drawn at a pixel's centre in the last frame (frame coordinates, or ECEF on the
  /// globe); none where nothing was drawn.
  [[nodiscard]] std::optional<glm::dvec3> pointAt(const glm::dvec2& pixel) const;
  /// pointAt in the coordinates a person reads.
  [[nodiscard]] std::optional<GroundPoint> groundAt(const glm::dvec2& pixel) const;
  /// "EPSG:31985", or "CRS" when the scene's CRS has no code.
  [[nodiscard]] std::string crsName() const;
  /// The selected features as GeoJSON: `path` (RFC 7946, every layer) and selected_<layer>.geojson
  /// beside it per layer in its source's CRS, in a projected scene or on the globe; false when
  /// nothing is selected or a file could not be written.
  bool exportSelection(const std::filesystem::path& path);
  /// Scene only (`ui` false: also <stem>_depth.tiff and <stem>_camera.json beside it), or the
  /// whole window as shown.
  bool screenshot(const std::filesystem::path& path, bool ui);

  // The frames (viewer.cpp, viewer_navigation.cpp).
  /// Makes a loaded scene current in its frame (its renderer, the camera at home); a projected
  /// scene whose renderer fails leaves no scene (false).
  bool showScene(scene::Scene loaded, const scene::SceneDescription& description);
  /// The scene's ground in its frame (scene::Scene::projected, globe): the frame it is not in is a
  /// caller error.
  [[nodiscard]] scene::LoadedScene& projected() { return scene_->projected(); }
  [[nodiscard]] const scene::LoadedScene& projected() const { return scene_->projected(); }
  [[nodiscard]] scene::LoadedGlobeScene& globeScene() { return scene_->globe(); }
  [[nodiscard]] const scene::LoadedGlobeScene& globeScene() const { return scene_->globe(); }
  /// Home on the globe: the scene's camera, else its data's extent framed.
  void globeHome();
  /// The selection as state() has it in both frames: the steps, the lassos and the selected
  /// features per layer.
  [[nodiscard]] nlohmann::json selectionJson() const;
  /// The globe's camera and what it drew, for state() (frameStateJson).
  [[nodiscard]] nlohmann::json globeStateJson() const;

  // Script (viewer_script_runner.cpp).
  /// This frame's part of the script: played input, a live step (`window`: the window's input),
  /// waits, or the next steps.
  void advanceScript(double seconds, const InputFrame& window);
  bool runStep(const app::ScriptStep& step);  ///< false: the step failed (reported)

  void message(const std::string& text, bool error = false);
  /// Each kind of diagnostic once, with its count and first features (groupDiagnostics: a layer
  /// of 16,906 one-point lines is one message), an error as an error; `where` (a script step)
  /// before each; with `errors`, every one said as an error.
  void message(const Diagnostics& diagnostics, const std::string& where = {}, bool errors = false);
  /// A message that also shows for a few seconds at the top of the window (export, screenshot).
  void notify(const std::string& text, bool error = false);
  /// Drops the notice once its time is up (it is shown in the status bar, drawStatusBar).
  void expireNotice();

  [[nodiscard]] glm::ivec2 framebufferSize() const;
  /// Window (screen) coordinates → framebuffer pixels (high-DPI).
  [[nodiscard]] glm::dvec2 toPixels(const glm::dvec2& window) const;
  [[nodiscard]] scene::Camera camera() const;
  [[nodiscard]] double aspect() const;

  std::unique_ptr<gfx::Context> context_;
  ViewerOptions options_;
  app::ViewerSettings settings_;
  std::optional<scene::SceneDescription> description_;
  std::unique_ptr<PendingLoad> loading_;
  std::size_t loadingFramesShown_ = 0;  ///< frames drawn with the loading window
  double lastLoadProgress_ = -1.0;      ///< the last load's last reported fraction (-1: none)
  /// The DEM's lowest and highest post (true heights): the elevation tint's range.
  std::optional<std::pair<double, double>> demRange_;
  std::optional<scene::Scene> scene_;               ///< the scene shown, in either frame
  std::unique_ptr<GlobeMode> globe_;                ///< the globe's renderer and camera, when scene_ is on the globe
  std::unique_ptr<scene::FrameRenderer> renderer_;  ///< draws scene_ in its frame (GL objects: the GL thread's)
  std::optional<scene::CameraController> controller_;
  std::optional<overlay::SelectionRenderer> selectionRenderer_;
  std::optional<gfx::RenderTarget> target_;
  gfx::StateCache cache_;
  scene::FrameOptions render_;  ///< how the frames are drawn (the panel's switches)
  const overlay::TechniqueInfo* technique_ = &overlay::defaultTechnique();
  int drapeSize_ = 2048;  ///< texture techniques: texels per side
  bool imgui_ = false;
  std::string font_;  ///< the panel's font file

  // Selection.
  std::vector<overlay::SelectionStep> steps_;
  std::vector<std::vector<overlay::SelectionStep>> undo_, redo_;  ///< the steps before (after) each change
  std::optional<scene::SelectedFeatures> selected_;               ///< the logical selection, once its job is done
  std::future<scene::SelectedFeatures> selectionJob_;             ///< the frame's selection on a worker
  std::size_t selectionGeneration_ = 0;                           ///< counts changes of the lassos
  std::size_t jobGeneration_ = 0;                                 ///< the lassos the running job selects with
  overlay::SelectionStyle highlight_;
  bool lassoTool_ = false;
  std::vector<glm::dvec2> lassoPoints_;  ///< being drawn, framebuffer pixels

  // Views and panels.
  bool showHelp_ = false;
  std::optional<float> exaggerationEdit_;  ///< the exaggeration slider's value while it is dragged
  std::array<char, 512> exportBuffer_{};   ///< the export path's field
  bool exportEditing_ = false;
  /// Where controls were drawn (window units: x0, y0, x1, y1), in save_state for tests.
  std::map<std::string, glm::vec4> uiRects_;
  bool debugPieces_ = false;
  /// The debug view of pieces (both frames): z-pass pieces green, z-fail red, translucent.
  static constexpr glm::vec4 kZPassPieceColour{0.1F, 0.8F, 0.2F, 0.35F};
  static constexpr glm::vec4 kZFailPieceColour{0.9F, 0.1F, 0.1F, 0.5F};
  std::optional<Identified> identified_;
  std::optional<AttributeTable> table_;
  FileBrowser browser_;
  bool showLabels_ = false;
  std::map<std::size_t, LabelSet> labelSets_;  ///< by scene layer
  app::LabelPlacer labelPlacer_;
  std::size_t labelsPlaced_ = 0;
  std::map<std::string, glm::vec4> windowRects_;  ///< the panel's windows as drawn (x0, y0, x1, y1)
  bool measureTool_ = false;
  bool measureClosed_ = false;
  std::vector<glm::dvec2> measurePoints_;  ///< frame x/y (on the globe lon/lat), in order
  std::optional<scene::Measurement> measurement_;
  std::vector<float> frameDepth_;
  std::size_t depthFrame_ = 0;  ///< the frame frameDepth_ was read in (0: none)
  bool showLegend_ = true;
  std::map<std::pair<std::size_t, std::size_t>, std::vector<std::vector<glm::dvec3>>>
      outlines_;  ///< by scene layer and feature
  double outlinesExaggeration_ = 0.0;
  std::size_t highlightedCount_ = 0;         ///< features outlined in the last frame
  std::optional<GroundPoint> cursorGround_;  ///< under the cursor in the last frame
  float panelRight_ = 0.0F;                  ///< the panel's right edge as last drawn, window units (0: not yet)
  float panelFont_ = 0.0F;                   ///< the panel's font size, window units (0: not yet)
  double scaleBarMetres_ = 0.0;              ///< the scale bar's length as last drawn (0: none)
  double compassAngle_ = 0.0;                ///< north on screen, radians clockwise from up, as last drawn
  scene::FrameFigures figures_;              ///< the last frame's (GPU times and fragments: the last measured one's)
  double frameMs_ = 16.0;
  double selectionMs_ = 0.0;  ///< wall time of the last logical selection (features and posts)
  std::size_t frameIndex_ = 0;
  struct Notice {
    std::string text;
    double until = 0.0;  ///< glfwGetTime
    bool error = false;
  };
  std::optional<Notice> notice_;
  std::vector<std::string> messages_;  ///< each said once, in order
  struct CacheShown {
    std::string directory;  ///< empty: no cache
    scene::CacheUsage usage;
    std::chrono::steady_clock::time_point counted;
  };
  std::optional<CacheShown> cacheShown_;
  std::unordered_map<std::string, std::size_t> said_;  ///< how often each message was said

  // Input.
  glm::dvec2 lastPixel_{0.0};
  glm::dvec2 pressCursor_{0.0};
  bool leftDown_ = false, rightDown_ = false, middleDown_ = false;
  bool dragged_ = false;
  std::vector<std::string> dropped_;
  std::deque<InputEvent> events_;  ///< from GLFW's callbacks, not yet taken
  // The queue's state as of the events taken so far.
  glm::dvec2 cursorWindow_{0.0};
  bool cursorInside_ = true;
  std::array<bool, 3> buttonsDown_{};
  std::array<bool, 512> keysDown_{};    ///< by GLFW key (GLFW_KEY_LAST is 348)
  int redrawFrames_ = 2;                ///< frames still to draw after the last change (the panel settles)
  bool moving_ = false;                 ///< the camera moved in the last frame
  bool busy_ = false;                   ///< work arriving: tiles, pieces, a selection
  std::deque<InputFrame> scriptInput_;  ///< played mouse and keys, one per frame
  /// A script's live step: the window's own input until this file exists, for at most so many frames.
  std::optional<std::pair<std::filesystem::path, int>> live_;

  // Script.
  std::optional<app::ViewerScript> script_;
  std::size_t scriptStep_ = 0;
  int waitFrames_ = 0;
  bool animating_ = false;
  bool scriptFailed_ = false;
  bool quit_ = false;
  std::optional<std::pair<std::filesystem::path, bool>> pendingShot_;  ///< taken at the end of this frame

  friend struct Callbacks;
  friend struct StepRunner;
};

}  // namespace gis::viewer
