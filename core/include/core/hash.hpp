#pragma once
// A stable 64-bit hash of text (FNV-1a): names cache files after the paths they stand for and
// fingerprints what a cache was built from. Not for security.
#include <cstdint>
#include <cstdio>
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

}  // namespace gis
