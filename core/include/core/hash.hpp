#pragma once
// A stable 64-bit hash of text (FNV-1a): names cache files after the paths they stand for and
// fingerprints what a cache was built from. Not for security.
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <string_view>

namespace gis {

inline std::uint64_t stableHash(std::string_view text) {
  std::uint64_t h = 1469598103934665603ULL;
  for (const char c : text) {
    h ^= static_cast<unsigned char>(c);
    h *= 1099511628211ULL;
  }
  return h;
}

/// stableHash as 16 hexadecimal digits.
inline std::string stableHashHex(std::string_view text) {
  char out[17];
  std::snprintf(out, sizeof(out), "%016llx", static_cast<unsigned long long>(stableHash(text)));
  return out;
}

/// A stable 64-bit fingerprint of a stream of values (FNV-1a over 64-bit words): what a cache
/// of derived data was made from. Not for security.
class StableHasher {
 public:
  void add(std::uint64_t word) {
    h_ ^= word;
    h_ *= 1099511628211ULL;
    h_ ^= h_ >> 29U;
  }
  void add(double v) {
    std::uint64_t bits = 0;
    static_assert(sizeof(bits) == sizeof(v));
    std::memcpy(&bits, &v, sizeof(v));
    add(bits);
  }
  void add(std::string_view text) {
    add(static_cast<std::uint64_t>(text.size()));
    add(stableHash(text));
  }
  [[nodiscard]] std::uint64_t value() const { return h_; }

 private:
  std::uint64_t h_ = 1469598103934665603ULL;
};

}  // namespace gis
