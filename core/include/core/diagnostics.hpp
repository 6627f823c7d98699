#pragma once
// Diagnostics and results: loading never crashes on bad data; it returns what it could read
// together with messages that name the file, the layer and the feature.
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace gis {

enum class Severity { Info, Warning, Error };

/// One message about the input. `file`, `layer` and `feature` are empty when not applicable.
struct Diagnostic {
  Severity severity = Severity::Error;
  std::string file;
  std::string layer;
  std::string feature;
  std::string message;

  /// "file: layer 'x': feature 12: message" — the form users see in logs and stats.json.
  [[nodiscard]] std::string toString() const;
};

/// A list of diagnostics with helpers to add and query them.
class Diagnostics {
 public:
  void add(Diagnostic d) { items_.push_back(std::move(d)); }
  void append(const Diagnostics& other) { items_.insert(items_.end(), other.items_.begin(), other.items_.end()); }
  [[nodiscard]] const std::vector<Diagnostic>& items() const& { return items_; }
  /// On a temporary (`for (auto& d : f().items())`) the items move out, so they outlive it.
  [[nodiscard]] std::vector<Diagnostic> items() && { return std::move(items_); }
  [[nodiscard]] std::size_t count(Severity s) const;
  [[nodiscard]] bool hasErrors() const { return count(Severity::Error) > 0; }
  [[nodiscard]] bool empty() const { return items_.empty(); }

 private:
  std::vector<Diagnostic> items_;
};

/// A value (absent when loading failed as a whole) plus everything worth telling about it.
/// A value can be present *and* carry errors: e.g. a layer of which some features were broken.
template <typename T>
struct Result {
  std::optional<T> value;
  Diagnostics diagnostics;

  [[nodiscard]] bool ok() const { return value.has_value(); }
  explicit operator bool() const { return ok(); }
  T& operator*() { return *value; }
  const T& operator*() const { return *value; }
  T* operator->() { return &*value; }
  const T* operator->() const { return &*value; }

  static Result failure(Diagnostic d) {
    Result r;
    r.diagnostics.add(std::move(d));
    return r;
  }
};

}  // namespace gis
