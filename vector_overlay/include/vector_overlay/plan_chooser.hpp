#pragma once
// `auto`'s choice between two ways of drawing a frame, in both frames (the projected technique
// `auto`, techniques/auto_technique.cpp, and the globe's GlobeOverlayRenderer): plan 0 draws every
// layer with the stencil polyhedra, plan 1 the last layers with the deferred lookup. Both are
// exact, so the choice is only about time:
// - each plan's cost is its GPU time (a timer query around its passes, read a few frames later
//   without waiting; or what the passes measured themselves), averaged over its last measurements
//   (each new one weighs half);
// - plan 0 draws first; plan 1 draws the next frame to be measured; then the cheaper one draws and
//   the other is measured again every kProbeEvery frames. (Probing sooner after the camera moves,
//   every 6 frames, made the flights on Olinda 1.2× slower on llvmpipe: each probe of the dearer
//   plan costs a whole frame.)
#include <array>
#include <cstdint>
#include <deque>
#include <optional>

#include "gfx/queries.hpp"

namespace gis::overlay {

class PlanChooser {
 public:
  static constexpr int kProbeEvery = 24;

  /// The plan for the next frame; `second`: whether plan 1 can draw it at all (else 0). Takes in
  /// the measurements that have arrived first.
  int choose(bool second);
  /// Times the frame's passes for `plan` with a GPU timer (one timer query may run at a time:
  /// passes that time themselves report through record() instead).
  void begin(int plan);
  void end();
  /// A plan's cost as its passes measured it, in milliseconds.
  void record(int plan, double milliseconds);
  /// A plan's averaged cost so far (milliseconds), if measured.
  [[nodiscard]] std::optional<double> cost(int plan) const { return cost_[plan == 1 ? 1 : 0]; }

 private:
  struct Timing {
    gfx::GpuTimer timer;
    int plan = 0;
  };
  void harvest();

  std::deque<Timing> timings_;
  std::array<std::optional<double>, 2> cost_;
  std::uint64_t frameNumber_ = 0;
  std::array<std::optional<std::uint64_t>, 2> probedAt_;  ///< the last frame each plan drew
};

}  // namespace gis::overlay
