// The viewer's mouse and keys: queued from GLFW's callbacks and taken a frame at a time, or played
// from a script, and handled the same way.
#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <filesystem>
#include <limits>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>

#include "gfx/gl.hpp"  // before GLFW: libepoxy provides the GL declarations

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <glm/geometric.hpp>

#include "viewer.hpp"

namespace gis::viewer {

// GLFW calls plain functions; they reach the viewer through the window's user pointer. Input is
// queued, never applied at once; drops load at the next frame; focus and hover go to the panel.
struct Callbacks {
  static Viewer& of(GLFWwindow* w) { return *static_cast<Viewer*>(glfwGetWindowUserPointer(w)); }
  static void push(GLFWwindow* w, const InputEvent& e) {
    Viewer& v = of(w);
    v.events_.push_back(e);
    v.redrawFrames_ = std::max(v.redrawFrames_, 2);
  }
  static void cursor(GLFWwindow* w, double x, double y) {
    InputEvent e;
    e.kind = InputEvent::Kind::Cursor;
    e.value = {x, y};
    push(w, e);
  }
  static void button(GLFWwindow* w, int button, int action, int mods) {
    InputEvent e;
    e.kind = InputEvent::Kind::Button;
    e.code = button;
    e.action = action;
    e.mods = mods;
    push(w, e);
  }
  static void key(GLFWwindow* w, int key, int scancode, int action, int mods) {
    InputEvent e;
    e.kind = InputEvent::Kind::Key;
    e.code = key;
    e.scancode = scancode;
    e.action = action;
    e.mods = mods;
    push(w, e);
  }
  static void character(GLFWwindow* w, unsigned int c) {
    InputEvent e;
    e.kind = InputEvent::Kind::Char;
    e.code = static_cast<int>(c);
    push(w, e);
  }
  static void scroll(GLFWwindow* w, double dx, double dy) {
    InputEvent e;
    e.kind = InputEvent::Kind::Scroll;
    e.value = {dx, dy};
    push(w, e);
  }
  static void drop(GLFWwindow* w, int count, const char** paths) {
    for (int i = 0; i < count; ++i) of(w).dropped_.emplace_back(paths[i]);
    of(w).redrawFrames_ = std::max(of(w).redrawFrames_, 2);
  }
  static void focus(GLFWwindow* w, int focused) {
    ImGui_ImplGlfw_WindowFocusCallback(w, focused);
    of(w).redrawFrames_ = std::max(of(w).redrawFrames_, 2);
  }
  static void enter(GLFWwindow* w, int entered) {
    ImGui_ImplGlfw_CursorEnterCallback(w, entered);
    of(w).cursorInside_ = entered != 0;
    of(w).redrawFrames_ = std::max(of(w).redrawFrames_, 2);
  }
  static void refresh(GLFWwindow* w) { of(w).redrawFrames_ = std::max(of(w).redrawFrames_, 2); }
  static void resized(GLFWwindow* w, int, int) { of(w).redrawFrames_ = std::max(of(w).redrawFrames_, 2); }
};

void Viewer::installCallbacks() {
  GLFWwindow* window = context_->window();
  glfwSetWindowUserPointer(window, this);
  glfwSetCursorPosCallback(window, Callbacks::cursor);
  glfwSetMouseButtonCallback(window, Callbacks::button);
  glfwSetKeyCallback(window, Callbacks::key);
  glfwSetCharCallback(window, Callbacks::character);
  glfwSetScrollCallback(window, Callbacks::scroll);
  glfwSetDropCallback(window, Callbacks::drop);
  glfwSetWindowFocusCallback(window, Callbacks::focus);
  glfwSetCursorEnterCallback(window, Callbacks::enter);
  glfwSetWindowRefreshCallback(window, Callbacks::refresh);
  glfwSetFramebufferSizeCallback(window, Callbacks::resized);
  glfwGetCursorPos(window, &cursorWindow_.x, &cursorWindow_.y);
}

namespace {

bool isModifier(int key) {
  return key == GLFW_KEY_LEFT_SHIFT || key == GLFW_KEY_RIGHT_SHIFT || key == GLFW_KEY_LEFT_CONTROL ||
         key == GLFW_KEY_RIGHT_CONTROL || key == GLFW_KEY_LEFT_ALT || key == GLFW_KEY_RIGHT_ALT ||
         key == GLFW_KEY_LEFT_SUPER || key == GLFW_KEY_RIGHT_SUPER;
}

}  // namespace

InputFrame Viewer::takeInput() {
  GLFWwindow* window = context_->window();
  const ImGuiIO& io = ImGui::GetIO();
  InputFrame in;
  // The panel's claim on the mouse and keys is from the last frame: that is what was on screen
  // where the events happened.
  in.uiMouse = io.WantCaptureMouse;
  in.uiKeyboard = io.WantCaptureKeyboard;
  std::vector<int> keysChanged;
  bool took = false;
  while (!events_.empty()) {
    const InputEvent e = events_.front();
    if (e.kind == InputEvent::Kind::Button) {
      if (took) break;  // a frame of its own
      events_.pop_front();
      if (e.code >= 0 && e.code < static_cast<int>(buttonsDown_.size()))
        buttonsDown_[static_cast<std::size_t>(e.code)] = e.action == GLFW_PRESS;
      break;
    }
    const bool keyChange = e.kind == InputEvent::Kind::Key && e.action != GLFW_REPEAT;
    // While a text field takes the keyboard, typed characters come as Char events in order: the
    // keys of printable characters need no frame each (Enter, Backspace, arrows still do).
    const bool typed = keyChange && io.WantTextInput && e.code >= GLFW_KEY_SPACE && e.code <= GLFW_KEY_GRAVE_ACCENT &&
                       (e.mods & (GLFW_MOD_CONTROL | GLFW_MOD_ALT | GLFW_MOD_SUPER)) == 0;
    if (keyChange && !typed && std::find(keysChanged.begin(), keysChanged.end(), e.code) != keysChanged.end()) break;
    // A modifier's change starts a frame: keys pressed before it see it as it was (Ctrl+A in
    // the panel's text fields, whose Ctrl is read at the end of the frame).
    if (keyChange && !keysChanged.empty() && isModifier(e.code)) break;
    if (keyChange) keysChanged.push_back(e.code);
    events_.pop_front();
    took = true;
    switch (e.kind) {
      case InputEvent::Kind::Cursor:
        cursorWindow_ = e.value;
        in.cursorPath.push_back(toPixels(e.value));
        break;
      case InputEvent::Kind::Key:
        if (e.code >= 0 && e.code < static_cast<int>(keysDown_.size()) && e.action != GLFW_REPEAT) {
          keysDown_[static_cast<std::size_t>(e.code)] = e.action == GLFW_PRESS;
        }
        if (e.action == GLFW_PRESS) {
          app::Modifiers held;
          held.shift = (e.mods & GLFW_MOD_SHIFT) != 0;
          held.ctrl = (e.mods & GLFW_MOD_CONTROL) != 0;
          held.alt = (e.mods & GLFW_MOD_ALT) != 0;
          in.pressed.push_back({e.code, held});
        }
        ImGui_ImplGlfw_KeyCallback(window, e.code, e.scancode, e.action, e.mods);
        break;
      case InputEvent::Kind::Char:
        ImGui_ImplGlfw_CharCallback(window, static_cast<unsigned int>(e.code));
        break;
      case InputEvent::Kind::Scroll:
        in.scroll += e.value.y;
        ImGui_ImplGlfw_ScrollCallback(window, e.value.x, e.value.y);
        break;
      case InputEvent::Kind::Button:
        break;
    }
  }
  in.cursor = toPixels(cursorWindow_);
  in.left = buttonsDown_[GLFW_MOUSE_BUTTON_LEFT];
  in.right = buttonsDown_[GLFW_MOUSE_BUTTON_RIGHT];
  in.middle = buttonsDown_[GLFW_MOUSE_BUTTON_MIDDLE];
  const auto down = [&](int a, int b) { return keyDown(a) || keyDown(b); };
  in.modifiers.shift = down(GLFW_KEY_LEFT_SHIFT, GLFW_KEY_RIGHT_SHIFT);
  in.modifiers.ctrl = down(GLFW_KEY_LEFT_CONTROL, GLFW_KEY_RIGHT_CONTROL);
  in.modifiers.alt = down(GLFW_KEY_LEFT_ALT, GLFW_KEY_RIGHT_ALT);
  for (const int k : {GLFW_KEY_W, GLFW_KEY_A, GLFW_KEY_S, GLFW_KEY_D, GLFW_KEY_Q, GLFW_KEY_E}) {
    if (keyDown(k)) in.held.push_back(k);
  }
  return in;
}

void Viewer::feedImGuiMouse() const {
  ImGuiIO& io = ImGui::GetIO();
  if (cursorInside_ || std::any_of(buttonsDown_.begin(), buttonsDown_.end(), [](bool b) { return b; })) {
    io.MousePos = ImVec2(static_cast<float>(cursorWindow_.x), static_cast<float>(cursorWindow_.y));
  }
  for (std::size_t i = 0; i < buttonsDown_.size(); ++i) io.MouseDown[i] = buttonsDown_[i];
}

void Viewer::idleTick() {
  const auto ready = [](const auto& job) {
    return job.valid() && job.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
  };
  std::error_code ec;
  if ((loading_ && loading_->ready()) || ready(selectionJob_) || (notice_ && glfwGetTime() > notice_->until) ||
      (live_ && std::filesystem::exists(live_->first, ec))) {
    redrawFrames_ = std::max(redrawFrames_, 1);
  }
}

double Viewer::idleWait() const {
  if (needsFrame()) return 0.0;
  double wait = std::numeric_limits<double>::infinity();
  // Look again soon for work on other threads (a scene being read, a selection being found);
  // a notice disappears when its time is up.
  if (loading_ || selectionJob_.valid() || live_) wait = 0.1;  // a live step looks for its file
  if (notice_) wait = std::min(wait, std::max(notice_->until - glfwGetTime(), 0.01));
  return wait;
}

bool Viewer::needsFrame() const {
  // A script draws every frame (time advances by frames), except while it hands the window to
  // the real mouse and keys: then the viewer behaves as without one.
  if ((script_ && !live_) || quit_ || pendingShot_ || !events_.empty() || !dropped_.empty() || redrawFrames_ > 0 ||
      moving_ || busy_ || animating_) {
    return true;
  }
  // Fly keys held move the camera every frame (in either frame).
  const bool flying = globe_ ? globe_->fly : controller_ && controller_->mode() == scene::CameraController::Mode::Fly;
  if (!flying) return false;
  for (const int k : {GLFW_KEY_W, GLFW_KEY_A, GLFW_KEY_S, GLFW_KEY_D, GLFW_KEY_Q, GLFW_KEY_E}) {
    if (keyDown(k)) return true;
  }
  return false;
}

overlay::SelectionOp lassoOpOf(const app::Modifiers& m) {
  if (m.alt) return overlay::SelectionOp::Xor;
  if (m.ctrl && m.shift) return overlay::SelectionOp::And;
  if (m.ctrl) return overlay::SelectionOp::Subtract;
  if (m.shift) return overlay::SelectionOp::Or;
  return overlay::SelectionOp::Single;
}

void Viewer::handleInput(double seconds, const InputFrame& in) {
  // A notice lasts until the next click or key (or its few seconds), in both frames.
  if ((in.left && !leftDown_) || (in.right && !rightDown_) || (in.middle && !middleDown_) || !in.pressed.empty())
    notice_.reset();
  const bool fly = flying();
  if (!in.uiMouse) handleMouse(in);
  leftDown_ = in.left;
  rightDown_ = in.right;
  middleDown_ = in.middle;
  lastPixel_ = in.cursor;
  if (!in.uiKeyboard && fly) {
    // W A S D over the ground, Q and E down and up, Shift faster.
    auto key = [&](int k) { return std::find(in.held.begin(), in.held.end(), k) != in.held.end() ? 1.0 : 0.0; };
    const glm::dvec3 move(key(GLFW_KEY_D) - key(GLFW_KEY_A), key(GLFW_KEY_W) - key(GLFW_KEY_S),
                          key(GLFW_KEY_E) - key(GLFW_KEY_Q));
    if (move != glm::dvec3(0.0)) flyBy(move * (in.modifiers.shift ? 4.0 : 1.0), seconds);
  }
  if (!in.uiKeyboard) {
    for (const InputFrame::KeyPress& k : in.pressed) keyPressed(k.key, fly, k.modifiers);
  }
}

void Viewer::handleMouse(const InputFrame& in) {
  // The tools (lasso, measure, identify) are the same in both frames; the camera follows the rest
  // of the mouse in its frame's way (navigate).
  const glm::dvec2 pixel = in.cursor;
  const bool pressed = in.left && !leftDown_;
  if (pressed) {
    pressCursor_ = pixel;
    dragged_ = false;
    if (lassoTool_) lassoPoints_.assign(1, pixel);
  }
  // A drag starts once the cursor is 3 px from the press.
  const bool dragStarts = in.left && !dragged_ && glm::length(pixel - pressCursor_) > 3.0;
  if (dragStarts) dragged_ = true;
  if (in.left && lassoTool_ && !lassoPoints_.empty()) {
    // A left drag draws the lasso: every cursor position taken in the frame, so a fast drag keeps
    // its shape.
    for (const glm::dvec2& p : in.cursorPath) {
      if (glm::length(p - lassoPoints_.back()) >= 2.0) lassoPoints_.push_back(p);
    }
    if (glm::length(pixel - lassoPoints_.back()) >= 2.0) lassoPoints_.push_back(pixel);
  }
  navigate(in, pressed, dragStarts);
  if (!in.left && leftDown_) {
    if (lassoTool_ && lassoPoints_.size() >= 3) {
      overlay::SelectionOp op = lassoOpOf(in.modifiers);
      if (steps_.empty() && op != overlay::SelectionOp::Single) op = overlay::SelectionOp::Single;
      addLasso(op, std::exchange(lassoPoints_, {}));
    } else if (!dragged_ && measureTool_) {
      if (const std::optional<glm::dvec2> ground = measurePointAt(pixel)) addMeasurePoint(*ground);
    } else if (!dragged_) {
      identified_ = identify(pixel);
    }
    lassoPoints_.clear();
  }
}

void Viewer::keyPressed(int key, bool fly, const app::Modifiers& modifiers) {
  if (navigationKey(key)) return;  // the frame's own camera keys
  switch (key) {
    case GLFW_KEY_ESCAPE:
      // Backs out of one thing at a time, and never quits: nothing is lost to a stray key.
      if (!lassoPoints_.empty()) {
        lassoPoints_.clear();
      } else if (lassoTool_) {
        lassoTool_ = false;
      } else if (!measurePoints_.empty()) {
        clearMeasure();
      } else if (measureTool_) {
        measureTool_ = false;
      } else if (showHelp_) {
        showHelp_ = false;
      } else if (identified_) {
        identified_.reset();
      }
      break;
    case GLFW_KEY_H:
    case GLFW_KEY_HOME:
      goHome();
      break;
    case GLFW_KEY_N:
      northUp();
      break;
    case GLFW_KEY_F:
      setFlying(!fly);
      break;
    default:
      sharedKeyPressed(key, modifiers);
      break;
  }
}

void Viewer::sharedKeyPressed(int key, const app::Modifiers& modifiers) {
  switch (key) {
    // The lasso and measure tools: the same keys in a projected scene and on the globe.
    case GLFW_KEY_L:
      lassoTool_ = !lassoTool_;
      if (lassoTool_) measureTool_ = false;
      break;
    case GLFW_KEY_M:
      measureTool_ = !measureTool_;
      if (measureTool_) lassoTool_ = false;
      break;
    case GLFW_KEY_BACKSPACE:
      if (!measurePoints_.empty()) {
        measurePoints_.pop_back();
        remeasure();
      }
      break;
    case GLFW_KEY_Q:
      if (modifiers.ctrl) glfwSetWindowShouldClose(context_->window(), GLFW_TRUE);
      break;
    case GLFW_KEY_I:
      if (!steps_.empty()) invertSelection();
      break;
    case GLFW_KEY_C:
      clearSelection();
      break;
    case GLFW_KEY_Z:
      if (modifiers.ctrl && modifiers.shift) {
        redoSelection();
      } else if (modifiers.ctrl) {
        undoSelection();
      }
      break;
    case GLFW_KEY_Y:
      if (modifiers.ctrl) redoSelection();
      break;
    case GLFW_KEY_O:
      if (modifiers.ctrl) {
        openFileBrowser();
      } else {
        render_.overlays = !render_.overlays;
      }
      break;
    case GLFW_KEY_P:
      settings_.showPanel = !settings_.showPanel;
      break;
    case GLFW_KEY_U:
      settings_.showHud = !settings_.showHud;
      break;
    case GLFW_KEY_F12:
      pendingShot_ = {std::filesystem::path("terrain_viewer_" + std::to_string(frameIndex_) + ".png"), true};
      break;
    case GLFW_KEY_SLASH:  // '?' on most layouts (with Shift)
      showHelp_ = !showHelp_;
      break;
    default:
      break;
  }
}

int Viewer::keyCode(const std::string& name) {
  if (name.size() == 1) {
    const char c = static_cast<char>(std::tolower(static_cast<unsigned char>(name[0])));
    if (c >= 'a' && c <= 'z') return GLFW_KEY_A + (c - 'a');
    if (c >= '0' && c <= '9') return GLFW_KEY_0 + (c - '0');
    switch (c) {
      case '?':
      case '/':
        return GLFW_KEY_SLASH;
      case ' ':
        return GLFW_KEY_SPACE;
      default:
        return GLFW_KEY_UNKNOWN;
    }
  }
  static const std::array<std::pair<std::string_view, int>, 15> kNamed{{{"escape", GLFW_KEY_ESCAPE},
                                                                        {"enter", GLFW_KEY_ENTER},
                                                                        {"tab", GLFW_KEY_TAB},
                                                                        {"backspace", GLFW_KEY_BACKSPACE},
                                                                        {"insert", GLFW_KEY_INSERT},
                                                                        {"delete", GLFW_KEY_DELETE},
                                                                        {"right", GLFW_KEY_RIGHT},
                                                                        {"left", GLFW_KEY_LEFT},
                                                                        {"down", GLFW_KEY_DOWN},
                                                                        {"up", GLFW_KEY_UP},
                                                                        {"page_up", GLFW_KEY_PAGE_UP},
                                                                        {"page_down", GLFW_KEY_PAGE_DOWN},
                                                                        {"home", GLFW_KEY_HOME},
                                                                        {"end", GLFW_KEY_END},
                                                                        {"space", GLFW_KEY_SPACE}}};
  std::string n = name;
  std::transform(n.begin(), n.end(), n.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (const auto& [text, code] : kNamed) {
    if (n == text) return code;
  }
  for (int f = 1; f <= 25; ++f) {
    if (n == "f" + std::to_string(f)) return GLFW_KEY_F1 + f - 1;
  }
  return GLFW_KEY_UNKNOWN;
}

}  // namespace gis::viewer
