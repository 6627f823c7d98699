// `auto`'s choice between the stencil polyhedra and the deferred lookup (plan_chooser.hpp).
#include "vector_overlay/plan_chooser.hpp"

namespace gis::overlay {

int PlanChooser::choose(bool second) {
  harvest();
  ++frameNumber_;
  if (!second) return 0;
  int plan = 0;
  if (!cost_[0] || !cost_[1]) {
    plan = cost_[0] && !probedAt_[1] ? 1 : 0;
  } else {
    const int cheaper = *cost_[1] < *cost_[0] ? 1 : 0;
    const int other = 1 - cheaper;
    const std::uint64_t last = probedAt_[static_cast<std::size_t>(other)].value_or(0);
    plan = frameNumber_ - last >= static_cast<std::uint64_t>(kProbeEvery) ? other : cheaper;
  }
  probedAt_[static_cast<std::size_t>(plan)] = frameNumber_;
  return plan;
}

void PlanChooser::begin(int plan) {
  timings_.emplace_back();
  timings_.back().plan = plan;
  timings_.back().timer.begin();
}

void PlanChooser::end() {
  if (!timings_.empty()) timings_.back().timer.end();
}

void PlanChooser::record(int plan, double milliseconds) {
  std::optional<double>& c = cost_[plan == 1 ? 1U : 0U];
  c = c ? 0.5 * *c + 0.5 * milliseconds : milliseconds;
}

void PlanChooser::harvest() {
  while (!timings_.empty()) {
    const std::optional<std::uint64_t> ns = timings_.front().timer.nanoseconds(false);
    if (!ns && timings_.size() < 8) break;
    const std::uint64_t value = ns ? *ns : timings_.front().timer.nanoseconds(true).value_or(0);
    record(timings_.front().plan, static_cast<double>(value) * 1e-6);
    timings_.pop_front();
  }
}

}  // namespace gis::overlay
