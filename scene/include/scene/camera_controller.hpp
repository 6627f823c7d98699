#pragma once
// Interactive camera for the desktop viewer: orbit, grab-pan and zoom-to-cursor around a target,
// WASD flying, a shown camera that eases towards a goal, scripted keyframes and terrain following.
// Pure maths on scene::Camera: no GL, no window, so every gesture can be tested without a display.
#include <functional>
#include <numbers>
#include <optional>
#include <utility>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "scene/camera.hpp"

namespace gis::scene {

/// Height of the drawn terrain surface at frame (x, y) in metres (exaggerated), NaN off the terrain.
using HeightAt = std::function<double(const glm::dvec2&)>;

/// Tuning of the controller. Values out of range are replaced by sane ones when the controller is built.
struct ControllerSettings {
  double orbitRadiansPerPixel = 0.005;  ///< orbit: yaw and pitch per pixel of mouse drag
  double zoomPerWheelStep = 0.85;       ///< distance factor per wheel step towards the point
  double flySpeedPerSecond = 1.0;       ///< fraction of the height above ground per second (speed scales with altitude)
  double minFlySpeed = 5.0;             ///< m/s: flying speed near the ground, where the height-based speed vanishes
  double lookRadiansPerPixel = 0.003;   ///< fly: yaw and pitch of the view direction per pixel of mouse motion
  double smoothing = 12.0;              ///< 1/s: exponential approach of the shown camera to the goal (0 = none)
  double groundClearance = 2.0;         ///< metres: the eye never comes closer to the ground than this
  double minPitch = 0.02;               ///< radians below the horizon, orbit: just above the horizon
  double maxPitch = std::numbers::pi / 2.0;  ///< radians below the horizon, orbit: straight down
};

/// A view as the controller keeps it: the eye sits `distance` from `target`, `pitch` radians above the
/// target's horizontal plane (the view looks that far down) on the side given by `yaw` (0: south of the
/// target, looking north; positive turns the heading anticlockwise seen from above). There is no roll.
struct OrbitPose {
  glm::dvec3 target{0.0};    ///< frame coordinates, metres
  double yaw = 0.0;          ///< radians, in [-pi, pi]
  double pitch = 0.5;        ///< radians, in [-pi/2, pi/2]; pi/2 looks straight down
  double distance = 1000.0;  ///< metres from the eye to the target, in [1, 1e7]
  double fovYDeg = 45.0;     ///< vertical field of view, degrees

  /// Exact equality (the controller uses it to tell whether the shown camera moved).
  bool operator==(const OrbitPose&) const = default;
};

/// Mouse and keyboard camera control for a terrain viewer (like Google Earth or osgEarth's
/// EarthManipulator). Gestures change a goal; `update` moves the shown camera towards it once per frame
/// and keeps both above the terrain.
class CameraController {
 public:
  /// What the shown camera carries in a straight line on its way to the goal. Every gesture works in
  /// either mode; the mode names the gestures meant for it.
  enum class Mode {
    Orbit,  ///< rotate, pan and zoom around a target; the shown target glides to the goal target
    Fly,    ///< move the eye with keys and turn the view around it; the shown eye glides to the goal eye
  };

  /// Starts at `home` (which is also the view `goHome` returns to), in orbit mode.
  explicit CameraController(const Camera& home, ControllerSettings settings = {});

  /// The view `goHome` returns to. Ignored if it holds non-finite numbers.
  void setHome(const Camera& home);
  /// Smooth move to the home view (at the settings' smoothing rate).
  void goHome();
  /// Turns the goal to look along heading `yaw` (OrbitPose::yaw), keeping pitch and distance:
  /// about the target in orbit mode, about the eye in fly mode (north-up: the yaw of north).
  void setHeading(double yaw);
  /// Shown camera and goal both become `c` (no animation). Ignored if `c` holds non-finite numbers.
  void jumpTo(const Camera& c);
  /// Scripted keyframe: the shown camera moves from where it is to `c` over `seconds` with smoothstep
  /// easing and is exactly at `c` once `seconds` have passed in `update`. Any gesture that moves the goal
  /// ends the animation (idle input, such as fly with no key down, does not). `seconds` not positive and
  /// finite: as jumpTo.
  void animateTo(const Camera& c, double seconds);

  /// The current mode.
  [[nodiscard]] Mode mode() const { return mode_; }
  /// Switches mode without moving the view: fly keeps eye and direction; back in orbit the target lies on
  /// the view direction at the distance it had before.
  void setMode(Mode mode) { mode_ = mode; }

  /// Orbit: rotates the goal around its target (yaw about +z from horizontal motion, pitch from vertical
  /// motion, dragging down looks more steeply down). Target and distance stay; pitch stays within
  /// [minPitch, maxPitch] (a pitch already outside may only move back towards that range).
  void orbit(const glm::dvec2& deltaPixels);
  /// Orbit about the terrain: moves the target along the view axis to `distance` metres from the eye
  /// (where the terrain is at the centre of the view, say) without moving the view, so the next orbit
  /// turns around that point. Ignored while the shown camera is still on its way to the goal, and for a
  /// distance outside [1, 1e7] or not finite.
  void pivotAt(double distance);
  /// Grab-pan: the point under `from` on the horizontal plane through the goal target stays under the
  /// cursor at `to` (pixels: x right, y down, origin top-left). Rays are those of the goal camera, so
  /// quick successive drags add up while the shown camera catches up. Rays that miss the plane, or hit it
  /// more than 50 distances away, grab the plane point below where they are 50 distances out.
  void pan(const glm::dvec2& from, const glm::dvec2& to, const glm::ivec2& viewport);
  /// Zooms towards the point under the cursor: `pointUnderCursor` (from the depth buffer of the frame
  /// last drawn) when given and nearer than 1e9 m, else the cursor ray's hit with the target's horizontal
  /// plane (at most 50 distances out; the target's distance if the ray misses). Positive steps zoom in:
  /// the distance to that point and the orbit distance shrink by zoomPerWheelStep per step (orbit
  /// distance kept in [1, 1e7]); the goal camera moves so that the point ends up under the cursor (even
  /// if the shown camera, which the depth came from, has not yet caught up with the goal).
  void zoomAt(double wheelSteps, const glm::dvec2& cursor, const glm::ivec2& viewport,
              std::optional<glm::dvec3> pointUnderCursor);

  /// Fly: moves the goal eye (and its target) by `move` = (right, forward, up), each in [-1, 1] from the
  /// WASD/QE keys, for `seconds` (at most one second per call, so a stalled frame cannot throw the eye
  /// away). Forward is the view direction, right is horizontal, up is +z. The speed is flySpeedPerSecond
  /// times the height above ground at the last `update`, and at least minFlySpeed.
  void fly(const glm::dvec3& move, double seconds);
  /// Fly: turns the view direction around the goal eye (moving right turns right, moving down looks
  /// down), from straight up to straight down.
  void look(const glm::dvec2& deltaPixels);

  /// Advances the smoothing/animation by `seconds` (negative or NaN: none) and keeps the eye above
  /// ground, for goal and shown camera: an eye less than groundClearance above the highest ground within
  /// groundClearance (horizontally) of it is lifted to that height (orbit: the target stays and the view
  /// tilts; fly: the whole view rises). `height` may be empty (no terrain). Returns true while still
  /// moving: the shown camera changed in this call or has not yet reached the goal.
  bool update(double seconds, const HeightAt& height);

  /// The camera to draw with this frame. Its up vector is derived from the view (no roll, defined when
  /// looking straight down); the near plane is half the eye's height above ground at the last `update`,
  /// or half the distance to the target where that is smaller or there is no ground, within [0.05, 1000] m.
  [[nodiscard]] Camera camera() const;
  /// The camera the shown one moves towards (near plane chosen the same way).
  [[nodiscard]] Camera goal() const;
  /// The shown view as the controller keeps it.
  [[nodiscard]] const OrbitPose& shownPose() const { return shown_; }
  /// The goal view as the controller keeps it.
  [[nodiscard]] const OrbitPose& goalPose() const { return goal_; }
  /// Whether an `animateTo` keyframe is still playing.
  [[nodiscard]] bool animating() const { return animation_.has_value(); }

  /// The world ray through a pixel of this frame's camera (origin = eye, unit direction). Vertical field
  /// of view fovYDeg, aspect = viewport.x / viewport.y, pixel centres at (x + 0.5, y + 0.5).
  [[nodiscard]] std::pair<glm::dvec3, glm::dvec3> rayThrough(const glm::dvec2& pixel, const glm::ivec2& viewport) const;

 private:
  struct Animation {
    OrbitPose from;
    double seconds = 1.0;
    double elapsed = 0.0;
    bool eyeAnchored = false;  ///< the mode at the start: a mode switch must not change the path mid-way
  };

  [[nodiscard]] bool eyeAnchored() const { return mode_ == Mode::Fly; }
  [[nodiscard]] std::optional<OrbitPose> poseOf(const Camera& c) const;
  /// A gesture's result becomes the goal if it is finite; it ends a scripted animation (the shown camera
  /// then eases towards the new goal).
  void setGoal(const OrbitPose& goal);

  ControllerSettings settings_;
  Camera home_;
  Mode mode_ = Mode::Orbit;
  OrbitPose shown_;
  OrbitPose goal_;
  double shownNear_ = 1.0;
  double goalNear_ = 1.0;
  double goalAboveGround_ = 100.0;  ///< metres, at the last update: sets the flying speed
  std::optional<Animation> animation_;
};

}  // namespace gis::scene
