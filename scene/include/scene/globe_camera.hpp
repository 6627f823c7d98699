#pragma once
// Navigation around the globe (docs/globe.md), from space down to a metre above the ground: orbit
// around a target on the ground, grab-drag the globe, zoom to the cursor, heading and north-up,
// and a home view that frames a longitude/latitude box. Pure maths on a globe::GlobeView: no GL,
// no window, so every gesture can be tested without a display.
#include <numbers>
#include <optional>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "globe/ellipsoid.hpp"
#include "globe/geo_grid.hpp"
#include "globe/globe_view.hpp"

namespace gis::scene {

/// Tuning of the globe camera. Values out of range are replaced by sane ones when the controller is built.
struct GlobeCameraSettings {
  double fovYDeg = 45.0;                             ///< vertical field of view of the views it makes
  double minHeight = 1.0;                            ///< metres: the eye never comes closer to the ground under it
  double maxHeight = 5e7;                            ///< metres: the eye never goes higher above the ellipsoid
  double zoomPerStep = 0.8;                          ///< factor on the eye's height above the ground per zoom step
  double minPitch = 5.0 * std::numbers::pi / 180.0;  ///< radians below the horizontal: orbit stops above the horizon
  double flySpeedPerSecond = 1.0;                    ///< fly: fraction of the eye's height above the ground per second
  double minFlySpeed = 5.0;  ///< fly: m/s near the ground, where the height-based speed vanishes
};

/// Where the camera is: it looks at `target` (on the ground) from `distance` metres away, along the
/// direction `heading` (radians clockwise from north, 0 = looking north) and `pitch` (radians below the
/// target's local horizontal, π/2 = straight down), both in the target's east-north-up frame. There is
/// no roll: the horizon stays level. At a pole, east and north are those of enuBasis at the target's
/// longitude (north points along the meridian lon + 180° at the north pole): a consistent frame, so
/// the heading there is defined too.
struct GlobePose {
  globe::Geodetic target;                 ///< degrees and metres; h is the ground height there
  double distance = 1e7;                  ///< metres from the eye to the target
  double heading = 0.0;                   ///< radians, (−π, π]
  double pitch = std::numbers::pi / 2.0;  ///< radians, [minPitch, π/2]
};

/// Mouse camera for the globe (like Google Earth or Cesium's ScreenSpaceCameraController). Every
/// gesture leaves the camera finite, the eye at least minHeight above the ground under it and at most
/// maxHeight above the ellipsoid; a gesture that cannot be done (a cursor off the globe, say) does what
/// it can or nothing. Pixels: x right, y down, origin top-left, pixel centres at (x + 0.5, y + 0.5).
class GlobeCameraController {
 public:
  /// `ground` (may be null: the ellipsoid, h = 0) must outlive the controller. Starts looking
  /// straight down at (0°, 0°) with the whole globe in view.
  explicit GlobeCameraController(const globe::GeoGrid* ground = nullptr, GlobeCameraSettings settings = {});

  /// Changes the ground (null: the ellipsoid); the target drops onto it and the limits are enforced.
  void setGround(const globe::GeoGrid* ground);
  /// Jumps to a pose (target height replaced by the ground height there, pitch clamped, limits
  /// enforced). Ignored if it holds non-finite numbers.
  void setPose(const GlobePose& pose);

  /// Looks straight down (heading 0) at the box (degrees; `east` may exceed 180, or be less than
  /// `west`, for a box across ±180°) from just far enough that the whole box fits `region` of the
  /// viewport (pixels, x0, y0, x1, y1 from the top left; none: the whole viewport), its middle in
  /// the region's middle: the part of the window a panel leaves free, as in a projected frame
  /// (scene::frameBoxInRegion). A box that cannot fit (wider than the hemisphere in view) gives the
  /// whole globe, its middle in the region's.
  void home(double west, double south, double east, double north, const glm::ivec2& viewport,
            const std::optional<glm::dvec4>& region = std::nullopt);
  /// Slides the view over the ground (distance, heading and pitch kept) so that the ground point
  /// now in the middle of the viewport (the target) is seen in the middle of `region` (pixels, as
  /// home's): a camera its author placed, shown in the part of the window a panel leaves free.
  /// Nothing moves where the region is the viewport, or the point cannot be brought there.
  void centreIn(const glm::ivec2& viewport, const glm::dvec4& region);
  /// Turns around the target: heading += dHeading (clockwise seen from above), pitch += dPitch
  /// (positive looks more steeply down), pitch within [minPitch, π/2]. The target stays where it is on
  /// screen (the middle).
  void orbit(double dHeading, double dPitch);
  /// Moves the eye towards (steps > 0) or away from the ground point under the cursor, scaling the
  /// eye's height above the ground by zoomPerStep per step (fast from space, slow near the ground),
  /// within [minHeight above the ground, maxHeight]. Heading and pitch stay; the ground point under the
  /// cursor stays under the cursor, clamped steps included, wherever the geometry allows it. A cursor
  /// off the globe, or a point that cannot stay (zooming out with the cursor near the limb), zooms
  /// towards the target instead.
  void zoomToCursor(double steps, const glm::dvec2& pixel, const glm::ivec2& viewport);
  /// As zoomToCursor, the cursor in normalised device coordinates (x right, y up, [−1, 1]).
  void zoomToCursorNdc(double steps, const glm::dvec2& ndc, const glm::ivec2& viewport);
  /// Drags the globe: the ground point under `fromPixel` moves under `toPixel`, the distance to the
  /// target, the heading relative to north (near the poles: relative to the globe) and the pitch kept,
  /// so it spins the globe from space and pans near the ground. If `fromPixel` misses the globe nothing
  /// happens; if the point cannot reach `toPixel` (beyond the limb) it moves as far along the way as it can.
  void grab(const glm::dvec2& fromPixel, const glm::dvec2& toPixel, const glm::ivec2& viewport);
  /// Turns about the target to look along `heading` (radians clockwise from north).
  void setHeading(double heading);
  /// Heading 0: north up on screen (at a pole: along the frame GlobePose describes).
  void northUp() { setHeading(0.0); }
  /// Fly (the viewer's WASD, QE): moves the eye by `move` = (right, forward, up), each in [−1, 1],
  /// for `seconds`, at flySpeedPerSecond × its height above the ground per second (at least
  /// minFlySpeed), as a projected frame's fly does. Forward and right move the eye and the target
  /// together over the ground (along the heading and across it; heading, pitch and distance
  /// kept); up raises the eye (down lowers it, to minHeight above the ground at most).
  void fly(const glm::dvec3& move, double seconds);
  /// Fly: turns the view about the eye (heading += dHeading clockwise, pitch += dPitch looking
  /// more steeply down, within [minPitch, π/2]); the eye stays where it is and the target is the
  /// ground point the eye then looks at from the same distance.
  void look(double dHeading, double dPitch);

  /// The view to draw with: near plane from the eye's height above the ground under it, up vector
  /// keeping the horizon level (the target's local up projected on the screen; the heading's
  /// direction when looking straight down).
  [[nodiscard]] globe::GlobeView view(int width, int height) const;
  /// The ground point under a pixel of this camera's view (ray against the ellipsoid raised to the
  /// ground height there), ECEF; empty if the ray misses the globe.
  [[nodiscard]] std::optional<glm::dvec3> groundPointAt(const glm::dvec2& pixel, const glm::ivec2& viewport) const;

  [[nodiscard]] const GlobePose& pose() const { return pose_; }
  [[nodiscard]] const globe::Geodetic& target() const { return pose_.target; }
  [[nodiscard]] double heading() const { return pose_.heading; }
  [[nodiscard]] double pitch() const { return pose_.pitch; }
  [[nodiscard]] double distance() const { return pose_.distance; }
  [[nodiscard]] const GlobeCameraSettings& settings() const { return settings_; }
  /// The eye, ECEF metres.
  [[nodiscard]] glm::dvec3 eye() const;
  /// The eye's height above the ground under it, metres.
  [[nodiscard]] double heightAboveGround() const;
  /// The ground height at (lon, lat): the GeoGrid's, or 0 without one.
  [[nodiscard]] double groundHeight(double lonDeg, double latDeg) const;

 private:
  /// What a solve must hold besides the point under the cursor.
  struct Hold {
    bool eyeHeight = false;  ///< true: the eye's ellipsoidal height = value; false: the distance = value
    double value = 0.0;
    double scale = 1.0;  ///< of the eye height's residual, metres
  };

  [[nodiscard]] std::optional<glm::dvec3> groundPointAtNdc(const GlobePose& p, const glm::dvec2& ndc,
                                                           double aspect) const;
  /// A pose with the target moved by (x, y) metres in the tangent plane at `base`'s target and the
  /// given distance; the heading kept relative to north, or carried along with the globe (`carry`).
  [[nodiscard]] GlobePose moved(const GlobePose& base, double x, double y, double distance, bool carry) const;
  /// The pose near `base` that shows `point` at `ndc` and holds `hold` (Newton's method); empty if it
  /// does not converge.
  [[nodiscard]] std::optional<GlobePose> place(const GlobePose& base, const glm::dvec3& point, const glm::dvec2& ndc,
                                               double aspect, const Hold& hold, bool carry) const;
  /// place() keeping north where it can (away from the poles), carrying the heading along otherwise.
  [[nodiscard]] std::optional<GlobePose> placeEither(const GlobePose& base, const glm::dvec3& point,
                                                     const glm::dvec2& ndc, double aspect, const Hold& hold) const;
  /// The target stays; the distance changes so that the eye is `eyeHeight` above the ellipsoid.
  [[nodiscard]] GlobePose withEyeHeight(const GlobePose& p, double eyeHeight) const;
  /// Limits: eye below maxHeight and at least minHeight above the ground (the distance changes).
  [[nodiscard]] GlobePose limited(GlobePose p) const;
  /// Takes `p` if it is finite.
  void accept(const GlobePose& p);

  const globe::GeoGrid* ground_ = nullptr;
  GlobeCameraSettings settings_;
  GlobePose pose_;
};

}  // namespace gis::scene
