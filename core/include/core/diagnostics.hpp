#pragma once
// Diagnostics and results: loading never crashes on bad data; it returns what it could read
// together with messages that name the file, the layer and the feature.
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
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

/// Messages of one kind, said once: what the log and the viewer show where a file repeats one
/// problem (16,906 one-point lines of a river layer are one line, not 16,906). stats.json keeps
/// every message.
///
/// A kind is one severity, file and layer and one message text once its numbers are set aside:
/// "non-finite coordinate at vertex 3" and "… at vertex 7" are one kind, whose text shows "N"
/// where the numbers differ and the number itself where all agree. Other text that differs (an
/// attribute's value in quotes, another key) makes another kind. Messages that name no feature are
/// about the file or the layer itself, and their numbers say which (layers[2], "2 of 6"): they are
/// grouped only when their whole text is the same.
struct DiagnosticGroup {
  Severity severity = Severity::Error;
  std::string file;
  std::string layer;
  std::string message;                ///< the kind's text ("N" for the numbers that differ)
  std::size_t count = 0;              ///< messages of this kind
  std::size_t features = 0;           ///< distinct features they name (0: they name none)
  std::vector<std::string> examples;  ///< the first features named, in the order they came
  /// The first message of the kind as it was (one of a kind is said as it was).
  Diagnostic first;

  /// One line for the log and the viewer: the first message's own toString() when it is alone,
  /// else "error: rivers.shp: layer 'rivers': 16,906 features: <message> (features 12, 40, 41,
  /// 97, 180, …)", or "… <message> (3 times)" for a message that names no feature.
  [[nodiscard]] std::string toString() const;
};

/// The kind of a message: its text with every number (digits, with a sign, decimals and an
/// exponent) replaced by "N". "vertex 12 (1.5, -2e3)" → "vertex N (N, N)".
[[nodiscard]] std::string messageKind(std::string_view message);

/// `diagnostics` grouped by kind (see DiagnosticGroup), in the order each kind first came, with the
/// first `examples` distinct features of each.
[[nodiscard]] std::vector<DiagnosticGroup> groupDiagnostics(const Diagnostics& diagnostics, std::size_t examples = 5);

/// `n` with a comma between thousands: 16906 → "16,906".
[[nodiscard]] std::string countText(std::size_t n);

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
