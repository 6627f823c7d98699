#include "core/diagnostics.hpp"

#include <algorithm>

namespace gis {

std::string Diagnostic::toString() const {
  std::string out;
  switch (severity) {
    case Severity::Info:
      out = "info: ";
      break;
    case Severity::Warning:
      out = "warning: ";
      break;
    case Severity::Error:
      out = "error: ";
      break;
  }
  if (!file.empty()) out += file + ": ";
  if (!layer.empty()) out += "layer '" + layer + "': ";
  if (!feature.empty()) out += "feature " + feature + ": ";
  out += message;
  return out;
}

std::size_t Diagnostics::count(Severity s) const {
  return static_cast<std::size_t>(
      std::count_if(items_.begin(), items_.end(), [s](const Diagnostic& d) { return d.severity == s; }));
}

}  // namespace gis
