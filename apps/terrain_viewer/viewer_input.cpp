// The viewer's mouse and keys: read from GLFW each frame, or played from a script, and handled
// the same way.
#include <algorithm>
#include <array>
#include <cctype>
#include <string>
#include <string_view>
#include <utility>

#include "gfx/gl.hpp"  // before GLFW: libepoxy provides the GL declarations

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <glm/geometric.hpp>

#include "viewer.hpp"

namespace gis::viewer {

// GLFW calls plain functions; they reach the viewer through the window's user pointer.
struct Callbacks {
  static Viewer& of(GLFWwindow* w) { return *static_cast<Viewer*>(glfwGetWindowUserPointer(w)); }
  static void scroll(GLFWwindow* w, double, double dy) {
    if (!ImGui::GetIO().WantCaptureMouse) of(w).scroll_ += dy;
  }
  static void drop(GLFWwindow* w, int count, const char** paths) {
    for (int i = 0; i < count; ++i) of(w).dropped_.emplace_back(paths[i]);
  }
  static void key(GLFWwindow* w, int key, int, int action, int) {
    if (action == GLFW_PRESS && !ImGui::GetIO().WantCaptureKeyboard) of(w).keysPressed_.push_back(key);
  }
};

void Viewer::installCallbacks() {
  GLFWwindow* window = context_->window();
  glfwSetWindowUserPointer(window, this);
  glfwSetScrollCallback(window, Callbacks::scroll);
  glfwSetDropCallback(window, Callbacks::drop);
  glfwSetKeyCallback(window, Callbacks::key);
}

InputFrame Viewer::readInput() {
  GLFWwindow* window = context_->window();
  const ImGuiIO& io = ImGui::GetIO();
  InputFrame in;
  glm::dvec2 cursor(0.0);
  glfwGetCursorPos(window, &cursor.x, &cursor.y);
  in.cursor = toPixels(cursor);
  in.left = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
  in.right = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS;
  in.middle = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_MIDDLE) == GLFW_PRESS;
  const auto down = [&](int a, int b) {
    return glfwGetKey(window, a) == GLFW_PRESS || glfwGetKey(window, b) == GLFW_PRESS;
  };
  in.modifiers.shift = down(GLFW_KEY_LEFT_SHIFT, GLFW_KEY_RIGHT_SHIFT);
  in.modifiers.ctrl = down(GLFW_KEY_LEFT_CONTROL, GLFW_KEY_RIGHT_CONTROL);
  in.modifiers.alt = down(GLFW_KEY_LEFT_ALT, GLFW_KEY_RIGHT_ALT);
  for (const int k : {GLFW_KEY_W, GLFW_KEY_A, GLFW_KEY_S, GLFW_KEY_D, GLFW_KEY_Q, GLFW_KEY_E}) {
    if (glfwGetKey(window, k) == GLFW_PRESS) in.held.push_back(k);
  }
  in.scroll = std::exchange(scroll_, 0.0);
  in.pressed = std::exchange(keysPressed_, {});
  in.uiMouse = io.WantCaptureMouse;
  in.uiKeyboard = io.WantCaptureKeyboard;
  return in;
}

namespace {

/// The lasso operator the modifiers choose (docs/viewer.md): Shift Or, Ctrl Subtract, Ctrl+Shift
/// And, Alt Xor; none: Single.
overlay::SelectionOp lassoOpOf(const app::Modifiers& m) {
  if (m.alt) return overlay::SelectionOp::Xor;
  if (m.ctrl && m.shift) return overlay::SelectionOp::And;
  if (m.ctrl) return overlay::SelectionOp::Subtract;
  if (m.shift) return overlay::SelectionOp::Or;
  return overlay::SelectionOp::Single;
}

}  // namespace

void Viewer::handleInput(double seconds, const InputFrame& in) {
  const bool fly = controller_->mode() == scene::CameraController::Mode::Fly;
  if (!in.uiMouse) handleMouse(in);
  leftDown_ = in.left;
  rightDown_ = in.right;
  middleDown_ = in.middle;
  lastPixel_ = in.cursor;

  if (!in.uiKeyboard && fly) {
    auto key = [&](int k) { return std::find(in.held.begin(), in.held.end(), k) != in.held.end() ? 1.0 : 0.0; };
    const glm::dvec3 move(key(GLFW_KEY_D) - key(GLFW_KEY_A), key(GLFW_KEY_W) - key(GLFW_KEY_S),
                          key(GLFW_KEY_E) - key(GLFW_KEY_Q));
    if (move != glm::dvec3(0.0)) controller_->fly(move * (in.modifiers.shift ? 4.0 : 1.0), seconds);
  }
  for (const int k : in.pressed) keyPressed(k, fly);
}

void Viewer::handleMouse(const InputFrame& in) {
  const glm::dvec2 pixel = in.cursor, lastPixel = lastPixel_;
  const glm::ivec2 fb = framebufferSize();
  const bool left = in.left, right = in.right, middle = in.middle;
  const bool fly = controller_->mode() == scene::CameraController::Mode::Fly;

  if (left && !leftDown_) {
    pressCursor_ = pixel;
    dragged_ = false;
    if (lassoTool_) lassoPoints_.assign(1, pixel);
    // Orbit about the terrain at the centre of the view: reversed-Z depth is near / distance
    // along the view axis.
    if (!lassoTool_ && !fly) {
      if (const std::optional<float> depth = depthAt(fb.x / 2, fb.y / 2)) {
        controller_->pivotAt(camera().nearPlane / static_cast<double>(*depth));
      }
    }
  }
  if (left && glm::length(pixel - pressCursor_) > 3.0) dragged_ = true;
  if (left && lassoTool_) {
    if (glm::length(pixel - lassoPoints_.back()) >= 2.0) lassoPoints_.push_back(pixel);
  } else if (left && leftDown_ && dragged_) {
    if (fly) {
      controller_->look(pixel - lastPixel);
    } else {
      controller_->orbit(pixel - lastPixel);
    }
  } else if ((right && rightDown_) || (middle && middleDown_)) {
    if (fly) {
      controller_->look(pixel - lastPixel);
    } else {
      controller_->pan(lastPixel, pixel, fb);
    }
  }
  if (!left && leftDown_) {
    if (lassoTool_ && lassoPoints_.size() >= 3) {
      overlay::SelectionOp op = lassoOpOf(in.modifiers);
      if (steps_.empty() && op != overlay::SelectionOp::Single) op = overlay::SelectionOp::Single;
      addLasso(op, std::exchange(lassoPoints_, {}));
    } else if (!dragged_) {
      identified_ = identify(pixel);
    }
    lassoPoints_.clear();
  }
  if (in.scroll != 0.0) {
    controller_->zoomAt(in.scroll, pixel, fb, pointAt(pixel));
  }
}

void Viewer::keyPressed(int key, bool fly) {
  switch (key) {
    case GLFW_KEY_ESCAPE:
      if (lassoTool_) {
        lassoTool_ = false;
        lassoPoints_.clear();
      } else if (showHelp_) {
        showHelp_ = false;
      } else {
        glfwSetWindowShouldClose(context_->window(), GLFW_TRUE);
      }
      break;
    case GLFW_KEY_H:
      controller_->goHome();
      break;
    case GLFW_KEY_F:
      controller_->setMode(fly ? scene::CameraController::Mode::Orbit : scene::CameraController::Mode::Fly);
      break;
    case GLFW_KEY_L:
      lassoTool_ = !lassoTool_;
      break;
    case GLFW_KEY_I:
      if (!steps_.empty()) invertSelection();
      break;
    case GLFW_KEY_C:
      clearSelection();
      break;
    case GLFW_KEY_O:
      render_.overlays = !render_.overlays;
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
