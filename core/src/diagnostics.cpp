#include "core/diagnostics.hpp"

#include <algorithm>
#include <unordered_map>
#include <unordered_set>

namespace gis {
namespace {

/// "error: file: layer 'x': " — what every message starts with.
std::string prefixOf(Severity severity, const std::string& file, const std::string& layer) {
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
  return out;
}

bool isDigit(char c) { return c >= '0' && c <= '9'; }
bool isAlphanumeric(char c) { return isDigit(c) || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); }

/// Stands for a number in a message's shape: a byte no message text holds.
constexpr char kNumberSlot = '\x01';

/// A message as text with slots, and the numbers that fill them, in order.
struct MessageShape {
  std::string text;
  std::vector<std::string> numbers;
};

MessageShape shapeOf(std::string_view m) {
  MessageShape s;
  s.text.reserve(m.size());
  std::size_t i = 0;
  while (i < m.size()) {
    // A minus sign belongs to the number unless it joins two words ("UTF-8", "ISO-8859-1").
    const bool sign = m[i] == '-' && i + 1 < m.size() && isDigit(m[i + 1]) && (i == 0 || !isAlphanumeric(m[i - 1]));
    if (!isDigit(m[i]) && !sign) {
      s.text += m[i++];
      continue;
    }
    std::size_t j = i + (sign ? 1 : 0);
    while (j < m.size() && isDigit(m[j])) ++j;
    if (j + 1 < m.size() && m[j] == '.' && isDigit(m[j + 1])) {
      ++j;
      while (j < m.size() && isDigit(m[j])) ++j;
    }
    if (j < m.size() && (m[j] == 'e' || m[j] == 'E')) {
      std::size_t k = j + 1;
      if (k < m.size() && (m[k] == '+' || m[k] == '-')) ++k;
      if (k < m.size() && isDigit(m[k])) {
        j = k;
        while (j < m.size() && isDigit(m[j])) ++j;
      }
    }
    s.numbers.emplace_back(m.substr(i, j - i));
    s.text += kNumberSlot;
    i = j;
  }
  return s;
}

/// The shape's text with its slots filled: `numbers[k]`, or "N" where `varies[k]`.
std::string filled(const std::string& text, const std::vector<std::string>& numbers, const std::vector<bool>& varies) {
  std::string out;
  std::size_t k = 0;
  for (const char c : text) {
    if (c != kNumberSlot) {
      out += c;
    } else {
      out += k < numbers.size() && !varies[k] ? numbers[k] : std::string("N");
      ++k;
    }
  }
  return out;
}

}  // namespace

std::string Diagnostic::toString() const {
  std::string out = prefixOf(severity, file, layer);
  if (!feature.empty()) out += "feature " + feature + ": ";
  out += message;
  return out;
}

std::size_t Diagnostics::count(Severity s) const {
  return static_cast<std::size_t>(
      std::count_if(items_.begin(), items_.end(), [s](const Diagnostic& d) { return d.severity == s; }));
}

std::string countText(std::size_t n) {
  std::string digits = std::to_string(n);
  for (std::size_t at = digits.size(); at > 3; at -= 3) digits.insert(at - 3, ",");
  return digits;
}

std::string messageKind(std::string_view message) {
  const MessageShape shape = shapeOf(message);
  return filled(shape.text, shape.numbers, std::vector<bool>(shape.numbers.size(), true));
}

std::string DiagnosticGroup::toString() const {
  if (count <= 1) return first.toString();
  std::string out = prefixOf(severity, file, layer);
  if (features == 0) return out + message + " (" + countText(count) + " times)";
  const char* plural = features == 1 ? "" : "s";
  out += count == features ? countText(count) + " features: "
                           : countText(count) + " messages about " + countText(features) + " feature" + plural + ": ";
  out += message + " (feature" + plural + " ";
  for (std::size_t k = 0; k < examples.size(); ++k) out += (k > 0 ? ", " : "") + examples[k];
  out += features > examples.size() ? ", …)" : ")";
  return out;
}

std::vector<DiagnosticGroup> groupDiagnostics(const Diagnostics& diagnostics, std::size_t examples) {
  std::vector<DiagnosticGroup> groups;
  // Per group: its shape's text, the first message's numbers, which of them differ in another,
  // and the features named so far.
  struct Numbers {
    std::string text;
    std::vector<std::string> first;
    std::vector<bool> varies;
    std::unordered_set<std::string> features;
  };
  std::vector<Numbers> numbers;
  std::unordered_map<std::string, std::size_t> groupOf;
  for (const Diagnostic& d : diagnostics.items()) {
    const bool named = !d.feature.empty();
    MessageShape shape = named ? shapeOf(d.message) : MessageShape{d.message, {}};
    std::string key;
    key.reserve(d.file.size() + d.layer.size() + shape.text.size() + 6);
    key += static_cast<char>('0' + static_cast<int>(d.severity));
    key += named ? 'f' : '-';
    for (const std::string* part : {&d.file, &d.layer, static_cast<const std::string*>(&shape.text)}) {
      key += '\0';
      key += *part;
    }
    const auto [at, added] = groupOf.try_emplace(std::move(key), groups.size());
    if (added) {
      DiagnosticGroup g;
      g.severity = d.severity;
      g.file = d.file;
      g.layer = d.layer;
      g.first = d;
      groups.push_back(std::move(g));
      const std::size_t slots = shape.numbers.size();
      numbers.push_back(Numbers{std::move(shape.text), std::move(shape.numbers), std::vector<bool>(slots, false), {}});
    } else {
      Numbers& n = numbers[at->second];
      for (std::size_t k = 0; k < n.first.size() && k < shape.numbers.size(); ++k) {
        n.varies[k] = n.varies[k] || shape.numbers[k] != n.first[k];
      }
    }
    DiagnosticGroup& g = groups[at->second];
    ++g.count;
    if (named && numbers[at->second].features.insert(d.feature).second) {
      ++g.features;
      if (g.examples.size() < examples) g.examples.push_back(d.feature);
    }
  }
  for (std::size_t i = 0; i < groups.size(); ++i) {
    groups[i].message = filled(numbers[i].text, numbers[i].first, numbers[i].varies);
  }
  return groups;
}

}  // namespace gis
